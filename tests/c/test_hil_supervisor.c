/* The plant's command supervisor: the safety policy of hil_supervisor.h, period by period; the
 * fault reset (a request, then consecutive enabling commands: never a single frame) and the
 * E2E-protected stop request. */
#include <string.h>

#include "hil_supervisor.h"
#include "rrr_test.h"

static rrr_hil_sup fresh(void)
{
    rrr_hil_sup s;
    const rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
    CHECK(rrr_hil_sup_init(&s, &cfg) == 0);
    return s;
}

static rrr_hil_voltage_cmd cmd(uint8_t counter, double u)
{
    const rrr_hil_voltage_cmd c = {(uint8_t)(counter & 15u), 1, 0, {u, -u, 2.0 * u}};
    return c;
}

static int period(rrr_hil_sup *s, double u[3])
{
    return rrr_hil_sup_next_period(s, u);
}

/* A valid command with the given counter and Enable / ResetFault bits. */
static void feed(rrr_hil_sup *s, uint8_t counter, uint8_t enable, uint8_t reset, double u)
{
    rrr_hil_voltage_cmd c = cmd(counter, u);
    c.enable = enable;
    c.reset_fault = reset;
    rrr_hil_sup_on_command(s, RRR_HIL_RX_OK, &c);
}

/* The full fault reset from counter c0: a request, then RRR_HIL_RESET_ENABLE_FRAMES enabling
 * commands, one per period; checks 0 V until the last one. Returns the next counter. */
static uint8_t reset_sequence(rrr_hil_sup *s, uint8_t c0, double u_after)
{
    double u[3];
    feed(s, c0, 0, 1, 0.0);
    CHECK(period(s, u) == 1 && u[0] == 0.0);
    for (unsigned i = 1; i <= RRR_HIL_RESET_ENABLE_FRAMES; ++i) {
        feed(s, (uint8_t)(c0 + i), 1, 0, u_after);
        const int last = i == RRR_HIL_RESET_ENABLE_FRAMES;
        CHECK(period(s, u) == (last ? 0 : 1));
        CHECK(u[0] == (last ? u_after : 0.0));
    }
    return (uint8_t)((c0 + RRR_HIL_RESET_ENABLE_FRAMES + 1u) & 15u);
}

static void test_normal_and_hold(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    for (uint8_t k = 0; k < 40; ++k) {
        const rrr_hil_voltage_cmd c = cmd(k, 0.1 * k);
        rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
        CHECK(period(&s, u) == 0);
        CHECK(u[0] == 0.1 * k && u[1] == -(0.1 * k) && u[2] == 2.0 * (0.1 * k));
    }
    /* one dropped frame: the last voltage is held, then the next counter (delta 2) is fine */
    CHECK(period(&s, u) == 0 && u[0] == 0.1 * 39);
    rrr_hil_voltage_cmd c = cmd(41, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 1.0);
    /* two dropped: held twice */
    CHECK(period(&s, u) == 0 && u[0] == 1.0);
    CHECK(period(&s, u) == 0 && u[0] == 1.0);
    c = cmd(44, 2.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 2.0);
    CHECK(s.faults == 0 && s.err.cmd_missed == 3 && s.err.fault_events == 0);
    /* Enable = 0: 0 V, not a fault */
    c = cmd(45, 2.0);
    c.enable = 0;
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 0.0 && s.faults == 0);
}

static void test_silent_controller(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    const rrr_hil_voltage_cmd c = cmd(0, 3.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 3.0);
    CHECK(period(&s, u) == 0 && u[0] == 3.0);  /* 1st silent period: hold */
    CHECK(period(&s, u) == 0 && u[0] == 3.0);  /* 2nd: hold */
    CHECK(period(&s, u) == 1 && u[0] == 0.0);  /* 3rd: 0 V and latched */
    CHECK(s.faults == RRR_HIL_FAULT_TIMEOUT && s.err.timeout == 1);
    for (int k = 0; k < 10; ++k) {
        CHECK(period(&s, u) == 1 && u[0] == 0.0 && u[1] == 0.0 && u[2] == 0.0);
    }
    CHECK(s.err.timeout == 1 && s.err.fault_events == 1 && s.err.cmd_missed == 13);
    /* the controller comes back: still 0 V (latched) */
    rrr_hil_voltage_cmd back = cmd(1, 3.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &back);
    CHECK(period(&s, u) == 1 && u[0] == 0.0);
    /* reset: the request and the enabling commands */
    (void)reset_sequence(&s, 2, 1.5);
    CHECK(s.faults == 0 && s.err.resets == 1 && u[0] == 0.0);
    feed(&s, 6, 1, 0, 1.5);
    CHECK(period(&s, u) == 0 && u[0] == 1.5);
    rrr_hil_plant_status st;
    rrr_hil_sup_status(&s, &st);
    CHECK(st.state == RRR_HIL_PLANT_RUNNING && st.fault_count == 1 && st.cmd_missed == 13);
}

static void test_immediate_faults(void)
{
    const struct {
        rrr_hil_rx rx;
        uint8_t fault;
    } cases[] = {{RRR_HIL_RX_BAD_CRC, RRR_HIL_FAULT_CRC},
                 {RRR_HIL_RX_OUT_OF_RANGE, RRR_HIL_FAULT_RANGE},
                 {RRR_HIL_RX_BAD_DLC, RRR_HIL_FAULT_FORMAT}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        rrr_hil_sup s = fresh();
        double u[3];
        rrr_hil_voltage_cmd c = cmd(0, 3.0);
        rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
        CHECK(period(&s, u) == 0 && u[0] == 3.0);
        /* a valid command, then a bad frame in the same period: the bad one wins, 0 V at once */
        c = cmd(1, 4.0);
        rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
        rrr_hil_sup_on_command(&s, cases[i].rx, NULL);
        CHECK(period(&s, u) == 1 && u[0] == 0.0);
        CHECK(s.faults == cases[i].fault && s.err.fault_events == 1);
        rrr_hil_plant_status st;
        rrr_hil_sup_status(&s, &st);
        CHECK(st.state == RRR_HIL_PLANT_FAULT && st.faults == cases[i].fault && st.zero_voltage == 1);
    }
}

static void test_counter(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    rrr_hil_voltage_cmd c = cmd(5, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c); /* repeated counter */
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_COUNTER && s.err.counter == 1);

    s = fresh();
    c = cmd(15, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0);
    c = cmd(2, 1.0); /* 15 -> 2 is a wrap-around delta of 3: accepted */
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && s.faults == 0);
    c = cmd(6, 1.0); /* delta 4 > max_delta_counter */
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_COUNTER);
}

static void test_external_and_config(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_BUS);
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_SYNC);
    CHECK(period(&s, u) == 1 && s.faults == (RRR_HIL_FAULT_BUS | RRR_HIL_FAULT_SYNC));
    CHECK(s.err.bus == 1 && s.err.sync == 1 && s.err.fault_events == 2);
    const rrr_hil_sup_config bad1 = {0u, 3u}, bad2 = {3u, 16u}, one = {1u, 1u};
    CHECK(rrr_hil_sup_init(&s, &bad1) == -1);
    CHECK(rrr_hil_sup_init(&s, &bad2) == -1);
    CHECK(rrr_hil_sup_init(&s, &one) == 0);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_TIMEOUT); /* max_missed 1: at once */
}

/* A supervisor with a latched CRC fault after a valid command with counter 0. */
static rrr_hil_sup faulted(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    feed(&s, 0, 1, 0, 2.0);
    CHECK(period(&s, u) == 0 && u[0] == 2.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_BAD_CRC, NULL);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_CRC);
    return s;
}

static void test_single_frame_never_clears(void)
{
    /* every single valid command (any counter, any Enable / ResetFault), on every kind of
     * latched fault: the fault stays latched and the plant at 0 V */
    const uint8_t kinds[] = {RRR_HIL_FAULT_TIMEOUT, RRR_HIL_FAULT_CRC, RRR_HIL_FAULT_COUNTER,
                             RRR_HIL_FAULT_RANGE, RRR_HIL_FAULT_FORMAT, RRR_HIL_FAULT_SYNC,
                             RRR_HIL_FAULT_BUS};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; ++i) {
        for (unsigned bits = 0; bits < 4u; ++bits) {
            for (uint8_t counter = 0; counter < 16u; ++counter) {
                rrr_hil_sup s = fresh();
                double u[3];
                feed(&s, 15, 1, 0, 2.0);
                CHECK(period(&s, u) == 0);
                s.faults = kinds[i]; /* as latched by any of the causes */
                feed(&s, counter, (uint8_t)(bits & 1u), (uint8_t)(bits >> 1), 3.0);
                CHECK(period(&s, u) == 1 && u[0] == 0.0 && u[1] == 0.0 && u[2] == 0.0);
                CHECK(s.faults != 0u && s.err.resets == 0);
            }
        }
    }
    /* the old single-frame reset (ResetFault = 1, Enable = 0) only arms the reset */
    rrr_hil_sup s = faulted();
    double u[3];
    feed(&s, 1, 0, 1, 0.0);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_CRC && s.reset_step == RRR_HIL_RESET_ARMED);
    rrr_hil_plant_status st;
    rrr_hil_sup_status(&s, &st);
    CHECK(st.state == RRR_HIL_PLANT_RESET && st.faults == RRR_HIL_FAULT_CRC);
    /* and no sequence shorter than the request plus RRR_HIL_RESET_ENABLE_FRAMES commands
     * clears anything: every sequence of up to 3 frames from a latched fault (counter steps 0,
     * 1, 2, 4; all Enable / ResetFault combinations; valid or with a bad CRC) */
    enum { LETTERS = 4 * 4 * 2 };
    static const uint8_t steps[4] = {0, 1, 2, 4};
    for (unsigned len = 1; len <= 3u; ++len) {
        unsigned total = 1;
        for (unsigned k = 0; k < len; ++k) {
            total *= LETTERS;
        }
        for (unsigned seq = 0; seq < total; ++seq) {
            rrr_hil_sup t = faulted();
            uint8_t counter = 0;
            unsigned rest = seq;
            for (unsigned k = 0; k < len; ++k, rest /= LETTERS) {
                const unsigned l = rest % LETTERS;
                counter = (uint8_t)((counter + steps[l % 4u]) & 15u);
                if ((l / 16u) != 0u) {
                    rrr_hil_sup_on_command(&t, RRR_HIL_RX_BAD_CRC, NULL);
                } else {
                    feed(&t, counter, (uint8_t)((l / 4u) & 1u), (uint8_t)((l / 8u) & 1u), 1.0);
                }
                CHECK(period(&t, u) == 1 && u[0] == 0.0);
            }
            CHECK(t.faults != 0u && t.err.resets == 0);
        }
    }
}

static void test_reset_sequence(void)
{
    /* the full sequence clears the latch; the voltage of its last command applies next */
    rrr_hil_sup s = faulted();
    double u[3];
    uint8_t next = reset_sequence(&s, 1, 2.5);
    CHECK(s.faults == 0 && s.err.resets == 1 && s.reset_step == RRR_HIL_RESET_IDLE);
    feed(&s, next, 1, 0, 3.5);
    CHECK(period(&s, u) == 0 && u[0] == 3.5);
    /* the request may be held for several periods, counters wrap around 15 -> 0 */
    s = faulted();
    for (uint8_t c = 1; c < 14; ++c) { /* plain commands change nothing */
        feed(&s, c, 1, 0, 1.0);
        CHECK(period(&s, u) == 1 && u[0] == 0.0);
    }
    feed(&s, 14, 0, 1, 0.0);
    CHECK(period(&s, u) == 1);
    next = reset_sequence(&s, 15, 1.25); /* 15 (held request), 0, 1, 2 */
    CHECK(next == 3 && s.faults == 0 && s.err.resets == 1);
    /* a supervisor faulted before any command: the request is the first command */
    s = fresh();
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_BUS);
    CHECK(period(&s, u) == 1);
    (void)reset_sequence(&s, 9, 0.5);
    CHECK(s.faults == 0 && s.err.resets == 1);
    /* every fault kind at once is cleared by one sequence */
    s = faulted();
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_SYNC);
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_BUS);
    (void)reset_sequence(&s, 1, 0.5);
    CHECK(s.faults == 0 && s.err.resets == 1);
}

static void test_reset_sequence_broken(void)
{
    double u[3];
    /* a counter gap (delta 2, which the normal rule accepts) after the request */
    rrr_hil_sup s = faulted();
    feed(&s, 1, 0, 1, 0.0);
    CHECK(period(&s, u) == 1);
    feed(&s, 3, 1, 0, 1.0);
    CHECK(period(&s, u) == 1 && s.reset_step == RRR_HIL_RESET_IDLE);
    CHECK(s.faults == (RRR_HIL_FAULT_CRC | RRR_HIL_FAULT_COUNTER) && s.err.counter == 1);
    for (uint8_t c = 4; c < 8; ++c) { /* the rest of the broken sequence clears nothing */
        feed(&s, c, 1, 0, 1.0);
        CHECK(period(&s, u) == 1);
    }
    CHECK(s.faults != 0u && s.err.resets == 0);
    (void)reset_sequence(&s, 8, 1.0); /* a fresh, complete sequence does */
    CHECK(s.faults == 0 && s.err.resets == 1);

    /* a gap between two enabling commands, and a repeated counter */
    for (int repeat = 0; repeat < 2; ++repeat) {
        s = faulted();
        feed(&s, 1, 0, 1, 0.0);
        feed(&s, 2, 1, 0, 1.0);
        feed(&s, repeat ? 2 : 4, 1, 0, 1.0);
        feed(&s, repeat ? 3 : 5, 1, 0, 1.0);
        feed(&s, repeat ? 4 : 6, 1, 0, 1.0);
        CHECK(period(&s, u) == 1 && (s.faults & RRR_HIL_FAULT_COUNTER) != 0u && s.err.resets == 0);
    }

    /* a bad CRC in the middle (a frame that is not E2E-valid) */
    s = faulted();
    feed(&s, 1, 0, 1, 0.0);
    feed(&s, 2, 1, 0, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_BAD_CRC, NULL);
    feed(&s, 3, 1, 0, 1.0);
    feed(&s, 4, 1, 0, 1.0);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_CRC && s.err.crc == 2 && s.err.resets == 0);
    /* a wrong DLC or an out-of-range voltage likewise */
    const rrr_hil_rx bad[] = {RRR_HIL_RX_BAD_DLC, RRR_HIL_RX_OUT_OF_RANGE};
    for (size_t i = 0; i < 2u; ++i) {
        s = faulted();
        feed(&s, 1, 0, 1, 0.0);
        feed(&s, 2, 1, 0, 1.0);
        feed(&s, 3, 1, 0, 1.0);
        rrr_hil_sup_on_command(&s, bad[i], NULL);
        feed(&s, 4, 1, 0, 1.0);
        CHECK(period(&s, u) == 1 && s.err.resets == 0 && s.reset_step == RRR_HIL_RESET_IDLE);
    }

    /* Enable dropped, both bits set, an external fault, a timeout: each aborts */
    for (int how = 0; how < 4; ++how) {
        s = faulted();
        feed(&s, 1, 0, 1, 0.0);
        CHECK(period(&s, u) == 1);
        feed(&s, 2, 1, 0, 1.0);
        CHECK(period(&s, u) == 1);
        if (how == 0) {
            feed(&s, 3, 0, 0, 1.0);
        } else if (how == 1) {
            feed(&s, 3, 1, 1, 1.0);
        } else if (how == 2) {
            rrr_hil_sup_raise(&s, RRR_HIL_FAULT_SYNC);
            feed(&s, 3, 1, 0, 1.0);
        } else {
            for (unsigned k = 0; k < s.cfg.max_missed; ++k) {
                CHECK(period(&s, u) == 1);
            }
            CHECK((s.faults & RRR_HIL_FAULT_TIMEOUT) != 0u);
            feed(&s, 3, 1, 0, 1.0);
        }
        CHECK(period(&s, u) == 1 && s.reset_step == RRR_HIL_RESET_IDLE);
        feed(&s, 4, 1, 0, 1.0);
        CHECK(period(&s, u) == 1 && s.faults != 0u && s.err.resets == 0);
    }
    /* a second request restarts the count: the enables before it do not add up */
    s = faulted();
    feed(&s, 1, 0, 1, 0.0);
    feed(&s, 2, 1, 0, 1.0);
    feed(&s, 3, 1, 0, 1.0);
    feed(&s, 4, 0, 1, 0.0);
    feed(&s, 5, 1, 0, 1.0);
    CHECK(period(&s, u) == 1 && s.faults != 0u && s.reset_enables == 1);
}

static void test_stop(void)
{
    double u[3];
    const rrr_hil_stop_cmd end = {1, RRR_HIL_STOP_END_OF_RUN};
    /* before any command there is no counter to check a stop against */
    rrr_hil_sup s = fresh();
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, &end) == 0 && s.err.stop_rejected == 1);
    /* unauthenticated stops are ignored and counted, without a fault */
    feed(&s, 0, 1, 0, 2.0);
    CHECK(period(&s, u) == 0 && u[0] == 2.0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_BAD_CRC, NULL) == 0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_BAD_DLC, NULL) == 0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OUT_OF_RANGE, NULL) == 0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, NULL) == 0);
    const rrr_hil_stop_cmd stale = {0, RRR_HIL_STOP_END_OF_RUN}; /* the last command's counter */
    const rrr_hil_stop_cmd jump = {4, RRR_HIL_STOP_END_OF_RUN};  /* delta 4 > max_delta_counter */
    const rrr_hil_stop_cmd reason = {1, 9};
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, &stale) == 0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, &jump) == 0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, &reason) == 0);
    CHECK(s.err.stop_rejected == 8 && s.stop == 0 && s.faults == 0 && s.err.fault_events == 0);
    CHECK(s.last_counter == 0); /* a rejected stop does not move the counter */
    feed(&s, 1, 1, 0, 2.5);     /* the run goes on */
    CHECK(period(&s, u) == 0 && u[0] == 2.5);
    /* the next counter of the command sequence: honoured; 0 V from now on, commands ignored */
    const rrr_hil_stop_cmd ok = {2, RRR_HIL_STOP_INTERRUPTED};
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, &ok) == 1);
    CHECK(s.stop == 1 && s.stop_reason == RRR_HIL_STOP_INTERRUPTED && s.last_counter == 2);
    feed(&s, 3, 1, 0, 2.5);
    CHECK(period(&s, u) == 1 && u[0] == 0.0 && s.faults == 0 && s.err.cmd_missed == 0);
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_BAD_CRC, NULL) == 1); /* stopped stays stopped */
    CHECK(s.err.stop_rejected == 8);
    /* a stop is honoured while a fault is latched (stopping is always safe), with a jump
     * within the counter tolerance */
    s = faulted();
    const rrr_hil_stop_cmd late = {3, RRR_HIL_STOP_FAULT};
    CHECK(rrr_hil_sup_on_stop(&s, RRR_HIL_RX_OK, &late) == 1 && s.stop_reason == RRR_HIL_STOP_FAULT);
}

/* The output stage both profiles share (rrr_hil_latch): latched with its code, 0 V while
 * latched or stopped (counted per period), cleared only by the explicit reset event. */
static void test_latch(void)
{
    rrr_hil_latch l;
    memset(&l, 0x5A, sizeof l);
    rrr_hil_latch_init(&l);
    CHECK(!l.latched && l.code == 0 && l.fault_events == 0 && l.resets == 0 && l.zero_periods == 0);
    double u[2] = {1.5, -2.0};
    CHECK(!rrr_hil_latch_blocks(&l, 0) && rrr_hil_latch_output(&l, 0, u, 2) == 0);
    CHECK(u[0] == 1.5 && u[1] == -2.0 && l.zero == 0 && l.zero_periods == 0);
    CHECK(rrr_hil_latch_reset(&l) == 0 && l.resets == 0); /* nothing latched: no effect */
    /* the stop input alone: 0 V, counted, nothing latched */
    CHECK(rrr_hil_latch_blocks(&l, 1) && rrr_hil_latch_output(&l, 1, u, 2) == 1);
    CHECK(u[0] == 0.0 && u[1] == 0.0 && l.zero == 1 && l.zero_periods == 1 && !l.latched);
    /* a fault: latched with its code; a second replaces the code and counts */
    rrr_hil_latch_fault(&l, 0x8130u);
    CHECK(l.latched && l.code == 0x8130u && l.fault_events == 1);
    rrr_hil_latch_fault(&l, 0x6320u);
    CHECK(l.latched && l.code == 0x6320u && l.fault_events == 2);
    for (int k = 0; k < 5; ++k) { /* every period 0 V, whatever the caller computed */
        u[0] = 3.0;
        u[1] = 4.0;
        CHECK(rrr_hil_latch_blocks(&l, 0) && rrr_hil_latch_output(&l, 0, u, 2) == 1);
        CHECK(u[0] == 0.0 && u[1] == 0.0 && l.zero == 1);
    }
    CHECK(l.zero_periods == 6 && l.latched);
    /* the reset event clears it, once */
    CHECK(rrr_hil_latch_reset(&l) == 1 && !l.latched && l.code == 0 && l.resets == 1);
    CHECK(rrr_hil_latch_reset(&l) == 0 && l.resets == 1);
    u[0] = 3.0;
    CHECK(rrr_hil_latch_output(&l, 0, u, 1) == 0 && u[0] == 3.0 && l.zero == 0);
    CHECK(l.zero_periods == 6 && l.fault_events == 2); /* counters only grow */
    /* the DBC supervisor's storage of its latch: the fault bits are the code, the counters
     * and the zero flag are err's and zero_applied */
    rrr_hil_sup s = fresh();
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_SYNC);
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_BUS);
    CHECK(s.faults == (RRR_HIL_FAULT_SYNC | RRR_HIL_FAULT_BUS) && s.err.fault_events == 2);
    double v[3] = {1.0, 1.0, 1.0};
    CHECK(period(&s, v) == 1 && v[0] == 0.0 && s.zero_applied == 1 && s.err.zero_periods == 1);
    rrr_hil_sup_raise(&s, 0); /* no fault bit: counted as today, nothing more latched */
    CHECK(s.faults == (RRR_HIL_FAULT_SYNC | RRR_HIL_FAULT_BUS) && s.err.fault_events == 3);
    rrr_hil_sup t = fresh();
    rrr_hil_sup_raise(&t, 0);
    CHECK(t.faults == 0 && t.err.fault_events == 1 && period(&t, v) == 0 && t.zero_applied == 0);
}

int main(void)
{
    test_latch();
    test_normal_and_hold();
    test_silent_controller();
    test_immediate_faults();
    test_counter();
    test_external_and_config();
    test_single_frame_never_clears();
    test_reset_sequence();
    test_reset_sequence_broken();
    test_stop();
    return rrr_test_report("test_hil_supervisor");
}
