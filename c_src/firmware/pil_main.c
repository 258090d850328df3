/*
 * The controller node as firmware (processor in the loop, `rrr hil pil`): the computed-torque
 * law of eq 15 with the closed-form model on a Cortex-M, bare metal (no OS, no heap), talking to
 * the plant over SLCAN on its UART, in the DBC profile's lockstep.
 *
 * The same sources as the Linux controller node where the node's code is not I/O: the frame
 * logic (c_src/hil/dbc/hil_dbc_ctrl.c: E2E-checked decoding, the state from JointState1..3, the
 * repeat rule, PlantStatus), the law with its 0 V policy and its log row
 * (c_src/hil/nodes/hil_controller_law.c over librrr's rrr_ctc), the codec
 * (c_src/hil/dbc/hil_codec.c over the cantools code) and librrr itself. This file is the loop
 * of hil_dbc_controller.c's run_lockstep on the board's I/O (board/mps2.h) instead of a
 * transport:
 *
 *   wait for the SLCAN channel to open; heartbeat "operational"; for k = 0 .. n-1: wait for the
 *   complete joint state with alive counter k mod 16 (at most the run block's timeout), u_k by
 *   the law, VoltageCmd(k) and, for k < n-1, Sync(k) (a heartbeat every 100 periods); at the
 *   end StopCmd (the reason from the exit status) and the heartbeat "stopped"; a run that
 *   completed while a PlantStatus reported the safety policy firing ends with status 7; a
 *   repeated JointState ends the run at once with status 8 (tampered input); a silent plant
 *   with status 3. Then the summary line on the console, and the firmware waits for the host to
 *   close the channel before it ends (under QEMU: QEMU exits with the status).
 *
 * Built twice (c_src/firmware/CMakeLists.txt): rrr_pil_m7 (Cortex-M7, double-precision FPU:
 * librrr's rrr_ctc in double) and rrr_pil_m4f (Cortex-M4F, single-precision FPU, with
 * PIL_REAL_FLOAT: the law of law/pil_law.h in float). The instructions of the law and of the
 * period's work (decoding the period's frames, the law, encoding the commands; not the serial
 * I/O and not the log) are counted on the board's timer and written to the timing UART.
 */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "hil_controller.h"
#include "hil_dbc_ctrl.h"
#include "mps2.h"
#include "pil_run.h"
#include "rrr_hil_logs.h"
#include "slcan.h"
#ifdef PIL_REAL_FLOAT
#include "pil_law.h"
#define PIL_LAW_NAME "float"
#else
#define PIL_LAW_NAME "double"
#endif

#define PROG "rrr_pil"

extern unsigned char __run_block[];
extern unsigned char __run_block_size[];

/* The firmware's state beside the controller's (one instance: no heap). */
typedef struct pil_fw {
    rrr_hil_ctrl c;        /* the model, the reference, the measured state, the log */
    rrr_hil_ctrl_opts o;   /* the gains (the rest of the node's options is not used) */
    rrr_hil_dbc_ctrl bus;  /* the frames */
    pil_slcan sl;          /* the serial line */
    uint32_t timeout_ms;   /* the longest wait for the plant's next state */
    uint32_t tx_frames;    /* frames sent */
    uint32_t tx_dropped;   /* frames not sent: the channel was not open */
    uint32_t law_ticks;    /* ticks of the law in the current period */
    uint32_t work_ticks;   /* ticks of the period's work (decode, law, encode) */
    uint32_t law_max, work_max; /* the largest per period, ticks */
    char why[160];         /* why the run ended */
#ifdef PIL_REAL_FLOAT
    pil_model fmodel;      /* the model and gains in float */
    pil_gains fgains;
#endif
} pil_fw;

static pil_fw fw;

static int end(int rc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(fw.why, sizeof fw.why, fmt, ap);
    va_end(ap);
    return rc;
}

static const char *exit_name(int rc)
{
    switch (rc) {
    case RRR_HIL_EXIT_OK:
        return "completed";
    case RRR_HIL_EXIT_SETUP:
        return "setup failed";
    case RRR_HIL_EXIT_PEER_LOST:
        return "peer lost";
    case RRR_HIL_EXIT_FAULT:
        return "fault";
    case RRR_HIL_EXIT_SAFETY:
        return "completed, safety policy fired";
    case RRR_HIL_EXIT_TAMPERED:
        return "tampered input";
    default:
        return "unknown";
    }
}

/* The law of the build, timed with interrupts off (an interrupt handler's instructions are not
 * the law's). */
static rrr_status law(const rrr_model *m, const rrr_ctc_gains *gains, const double q_ref[3],
                      const double qd_ref[3], const double qdd_ref[3], const double q[3],
                      const double qd[3], rrr_ctc_output *out)
{
    pil_irq_off();
    const uint32_t t0 = pil_ticks();
#ifdef PIL_REAL_FLOAT
    (void)m;
    (void)gains;
    pil_real qr[3], qdr[3], qddr[3], qm[3], qdm[3];
    for (int i = 0; i < 3; ++i) {
        qr[i] = (pil_real)q_ref[i];
        qdr[i] = (pil_real)qd_ref[i];
        qddr[i] = (pil_real)qdd_ref[i];
        qm[i] = (pil_real)q[i];
        qdm[i] = (pil_real)qd[i];
    }
    pil_ctc_output o;
    const rrr_status st = pil_ctc(&fw.fmodel, &fw.fgains, qr, qdr, qddr, qm, qdm, &o);
    if (st == RRR_OK) {
        for (int i = 0; i < 3; ++i) {
            out->u[i] = (double)o.u[i];
            out->u_n[i] = (double)o.u_n[i];
            out->u_c[i] = (double)o.u_c[i];
        }
        out->saturated = o.saturated;
    }
#else
    const rrr_status st = rrr_ctc(m, gains, q_ref, qd_ref, qdd_ref, q, qd, out);
#endif
    fw.law_ticks += pil_ticks() - t0;
    pil_irq_on();
    return st;
}

/* Send one frame as an SLCAN line (dropped while the channel is not open). */
static void send_frame(const rrr_hil_frame *f)
{
    char line[PIL_SLCAN_LINE_MAX + 1u];
    const size_t n = pil_slcan_format(f, line);
    if (n == 0u || !pil_slcan_can_send(&fw.sl)) {
        ++fw.tx_dropped;
        return;
    }
    pil_slcan_write(line, n);
    ++fw.tx_frames;
}

static int send_heartbeat(uint8_t nmt)
{
    rrr_hil_frame f;
    if (rrr_hil_dbc_ctrl_heartbeat(&fw.bus, nmt, &f) != 0) {
        return end(RRR_HIL_EXIT_FAULT, "heartbeat cannot be encoded");
    }
    send_frame(&f);
    return 0;
}

/* The next SLCAN event before the deadline: the line's reply is sent; a frame goes to *f.
 * Returns 1 for a frame, 0 for another event, -1 at the deadline. */
static int next_event(uint32_t deadline, pil_slcan_event *ev, rrr_hil_frame *f)
{
    for (;;) {
        const int ch = pil_slcan_getc_until(deadline);
        if (ch < 0) {
            return -1;
        }
        char reply[PIL_SLCAN_REPLY_MAX];
        size_t n;
        *ev = pil_slcan_feed(&fw.sl, (char)ch, f, reply, &n);
        if (n > 0u) {
            pil_slcan_write(reply, n);
        }
        if (n > 0u || *ev != PIL_SLCAN_NONE) {
            return *ev == PIL_SLCAN_FRAME;
        }
    }
}

/* Wait for the host to open the channel (as long as it takes: the host starts the run). */
static void wait_open(void)
{
    while (!pil_slcan_can_send(&fw.sl)) {
        pil_slcan_event ev;
        rrr_hil_frame f;
        (void)next_event(pil_ticks() - 1u + 0x7FFFFFFFu, &ev, &f);
    }
}

/* Wait for the complete joint state with alive counter want: 0, or an exit status. */
static int wait_state(uint8_t want)
{
    const uint32_t deadline = pil_ticks() + fw.timeout_ms * (PIL_BOARD_CLOCK_HZ / 1000u);
    for (;;) {
        pil_slcan_event ev;
        rrr_hil_frame f;
        const int got = next_event(deadline, &ev, &f);
        if (got < 0) {
            return end(RRR_HIL_EXIT_PEER_LOST, "plant lost: no joint state within %u ms",
                       (unsigned)fw.timeout_ms);
        }
        if (ev == PIL_SLCAN_CLOSED) {
            return end(RRR_HIL_EXIT_PEER_LOST, "plant lost: the host closed the SLCAN channel");
        }
        if (!got) {
            continue;
        }
        pil_irq_off();
        const uint32_t t0 = pil_ticks();
        const int h = rrr_hil_dbc_ctrl_rx(&fw.bus, &f, fw.c.run.k);
        fw.work_ticks += pil_ticks() - t0;
        pil_irq_on();
        if (h < 0) {
            return end(RRR_HIL_EXIT_TAMPERED, "%s: a frame the plant never sends (tampered input?)",
                       fw.bus.tampered);
        }
        if (h > 0) {
            memcpy(fw.c.q, fw.bus.q, sizeof fw.c.q);
            memcpy(fw.c.qd, fw.bus.qd, sizeof fw.c.qd);
            ++fw.c.states;
            if (fw.bus.pending == want) {
                return 0;
            }
        }
    }
}

/* Period k: the law, VoltageCmd(k), Sync(k) unless last, a heartbeat every 100 periods; the
 * instruction counts of the period. 0, or an exit status. */
static int period(uint32_t k, int last)
{
    double u[3];
    fw.law_ticks = 0u;
    const int enable = rrr_hil_ctrl_law(&fw.c, &fw.o, k, 1, u); /* logs its row (not timed) */
    rrr_hil_frame frames[3];
    unsigned n = 0u;
    pil_irq_off();
    const uint32_t t0 = pil_ticks();
    const rrr_hil_voltage_cmd cmd = rrr_hil_dbc_ctrl_command(k, enable, u);
    int bad = rrr_hil_encode_voltage_cmd(&cmd, &frames[n++]) != 0;
    if (!bad && !last) {
        const rrr_hil_sync s = {k};
        bad = rrr_hil_encode_sync(&s, &frames[n++]) != 0;
    }
    fw.work_ticks += pil_ticks() - t0 + fw.law_ticks;
    pil_irq_on();
    if (bad) {
        return end(RRR_HIL_EXIT_FAULT, "VoltageCmd or Sync cannot be encoded (u outside the DBC "
                   "range [-30, 30] V?)");
    }
    for (unsigned i = 0; i < n; ++i) {
        send_frame(&frames[i]);
    }
    rrr_hil_dbc_ctrl_sent(&fw.bus, &cmd);
    fprintf(pil_timing, "%lu,%lu,%lu\n", (unsigned long)k,
            (unsigned long)(fw.law_ticks * PIL_BOARD_NS_PER_TICK),
            (unsigned long)(fw.work_ticks * PIL_BOARD_NS_PER_TICK));
    fw.law_max = fw.law_ticks > fw.law_max ? fw.law_ticks : fw.law_max;
    fw.work_max = fw.work_ticks > fw.work_max ? fw.work_ticks : fw.work_max;
    fw.work_ticks = 0u;
    if (k % RRR_HIL_HEARTBEAT_PERIODS == 0u && k > 0u) {
        return send_heartbeat(RRR_HIL_NMT_OPERATIONAL);
    }
    return 0;
}

/* StopCmd with the reason of the exit status, then the heartbeat "stopped" (as the node). */
static void finish(int rc)
{
    rrr_hil_stop_reason reason = RRR_HIL_STOP_PLANT_LOST;
    if (rc == RRR_HIL_EXIT_OK) {
        reason = RRR_HIL_STOP_END_OF_RUN;
    } else if (rc == RRR_HIL_EXIT_FAULT) {
        reason = RRR_HIL_STOP_FAULT;
    }
    const rrr_hil_stop_cmd stop = rrr_hil_dbc_ctrl_stop(&fw.bus, reason);
    rrr_hil_frame f;
    if (rrr_hil_encode_stop_cmd(&stop, &f) == 0) {
        send_frame(&f);
    }
    if (rrr_hil_dbc_ctrl_heartbeat(&fw.bus, RRR_HIL_NMT_STOPPED, &f) == 0) {
        send_frame(&f);
    }
}

static int run_lockstep(void)
{
    wait_open();
    int rc = send_heartbeat(RRR_HIL_NMT_OPERATIONAL);
    const uint32_t n = (uint32_t)fw.c.ref.n;
    for (uint32_t k = 0; k < n && rc == 0; ++k) {
        fw.c.run.k = k;
        rc = wait_state((uint8_t)(k & 15u));
        if (rc == 0) {
            rc = period(k, k + 1u == n);
        }
    }
    if (rc == 0) {
        fw.c.run.k = n;
        rc = end(RRR_HIL_EXIT_OK, "all %lu periods of the reference", (unsigned long)n);
    }
    finish(rc);
    if (rc == RRR_HIL_EXIT_OK && (fw.bus.status_faulty != 0u || fw.bus.status_zero != 0u)) {
        const size_t len = strlen(fw.why);
        (void)snprintf(fw.why + len, sizeof fw.why - len,
                       "; the plant's safety policy fired: %lu PlantStatus frames with a fault, "
                       "%lu with 0 V",
                       (unsigned long)fw.bus.status_faulty, (unsigned long)fw.bus.status_zero);
        rc = RRR_HIL_EXIT_SAFETY;
    }
    return rc;
}

static void summary(int rc)
{
    printf("RRR_HIL_SUMMARY {\"node\": \"controller\", \"exit\": %d, \"stale\": 0, "
           "\"ctc_failed\": %lu, ",
           rc, (unsigned long)fw.c.ctc_failed);
    rrr_hil_dbc_ctrl_json(stdout, &fw.bus);
    printf("\"transport\": \"slcan\", \"tx_frames\": %lu, \"tx_dropped\": %lu, "
           "\"slcan\": {\"commands\": %lu, \"refused\": %lu, \"rx_frames\": %lu, "
           "\"bitrate_code\": %d}, \"target\": {\"law\": \"" PIL_LAW_NAME "\", "
           "\"stack_used_bytes\": %u, \"stack_reserved_bytes\": %u, "
           "\"law_instructions_max\": %lu, \"period_instructions_max\": %lu, "
           "\"instructions_per_tick\": %u}}\n",
           (unsigned long)fw.tx_frames, (unsigned long)fw.tx_dropped,
           (unsigned long)fw.sl.commands, (unsigned long)fw.sl.refused,
           (unsigned long)fw.sl.rx_frames, fw.sl.bitrate, (unsigned)pil_stack_used(),
           (unsigned)pil_stack_size(), (unsigned long)(fw.law_max * PIL_BOARD_NS_PER_TICK),
           (unsigned long)(fw.work_max * PIL_BOARD_NS_PER_TICK),
           (unsigned)PIL_BOARD_NS_PER_TICK);
    printf(PROG ": exit %d (%s) at period %lu: %s\n", rc, exit_name(rc),
           (unsigned long)fw.c.run.k, fw.why);
}

/* After the run: wait until the host has closed the channel (it has then read every frame), at
 * most 1 s (the host's watch gives an ended run's other process 5 s). */
static void wait_close(void)
{
    const uint32_t ms = fw.timeout_ms < 1000u ? fw.timeout_ms : 1000u;
    const uint32_t deadline = pil_ticks() + ms * (PIL_BOARD_CLOCK_HZ / 1000u);
    while (fw.sl.open != 0) {
        pil_slcan_event ev;
        rrr_hil_frame f;
        if (next_event(deadline, &ev, &f) < 0) {
            return;
        }
    }
}

static int setup(void)
{
    pil_run run;
    const char *why = "";
    if (pil_run_open(__run_block, (size_t)__run_block_size, &run, &why) != 0 ||
        pil_run_model(&run, &fw.c.model, &why) != 0) {
        return end(RRR_HIL_EXIT_SETUP, "%s", why);
    }
    fw.o.gains = run.gains;
    fw.timeout_ms = run.timeout_ms;
    /* the reference stays in flash: the law only reads it (rrr_hil_reference is not const) */
    fw.c.ref.n = run.periods;
    fw.c.ref.t = (double *)(uintptr_t)run.t;
    fw.c.ref.q = (double(*)[3])(uintptr_t)run.q;
    fw.c.ref.qd = (double(*)[3])(uintptr_t)run.qd;
    fw.c.ref.qdd = (double(*)[3])(uintptr_t)run.qdd;
    fw.c.log = pil_log;
    fw.c.ctc = law;
#ifdef PIL_REAL_FLOAT
    pil_model_from(&fw.c.model, &fw.fmodel);
    pil_gains_from(&fw.o.gains, &fw.fgains);
#endif
    fputs(RRR_HIL_CONTROLLER_LOG_HEADER, pil_log); /* gen/rrr_hil_logs.h */
    fputs("k,law,period\n", pil_timing);
    return 0;
}

int main(void)
{
    pil_board_init();
    pil_slcan_init(&fw.sl);
    rrr_hil_dbc_ctrl_init(&fw.bus, 1);
    printf(PROG ": the computed-torque controller (law in " PIL_LAW_NAME "), SLCAN on UART0\n");
    int rc = setup();
    if (rc == 0) {
        rc = run_lockstep();
    }
    summary(rc);
    wait_close();
    return rc;
}
