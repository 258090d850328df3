/*
 * Fuzz target of the bench's input parsers: the frame decoder (every id, dlc, payload), the
 * supervisor fed with whatever the decoder returns (commands and stop requests), sequences of
 * frames through one supervisor (the fault-reset sequence and the stop), and the socketcand
 * message parser.
 *
 * Input layout: byte 0 selects the parser:
 *  - bit 0 set: the rest is the text of one socketcand message;
 *  - bit 0 clear, bit 2 clear, bit 3 set: the rest is what one read() from a raw CAN socket
 *    returned (its length is the input's; bit 1: the socket is in CAN FD mode), converted with
 *    rrr_hil_sc_from_wire; a frame converts back (rrr_hil_sc_to_wire) to bytes of the same
 *    length that convert to the same frame, and is decoded;
 *  - bit 0 clear, bit 2 clear, bit 3 clear: one frame (bytes 1..2 id, 3 dlc, 4.. data; bit 1:
 *    extended id);
 *  - bit 0 clear, bit 2 set: a sequence of 12-byte records fed to one supervisor that starts
 *    with a latched fault: op, id (2 bytes), dlc, data[8]. op & 3: 0 feed the frame, 1 feed it
 *    and close the period, 2 close the period, 3 latch an external fault (op & 4: sync, else
 *    bus); op & 0x10: the frame is a VoltageCmd, op & 0x20: a StopCmd (else the id bytes
 *    decide); op & 0x40: its E2E CRC is made valid (so that counters and bits get explored).
 *    Invariants (a violation traps): 0 V whenever a fault is latched or a stop was honoured;
 *    a latch clears only after a reset request and RRR_HIL_RESET_ENABLE_FRAMES enabling
 *    commands with consecutive alive counters, all decoded valid, no new fault in between.
 *
 * libFuzzer (clang):  cmake -DRRR_HIL_FUZZ=ON -DCMAKE_C_COMPILER=clang ...; ./fuzz_hil_decode
 * Without clang, tests/c/test_hil_fuzz_smoke.c drives the same function with random inputs.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_supervisor.h"
#include "hil_transport.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* One frame: decode, re-encode what decoded, feed a fresh supervisor. */
static void one_frame(const uint8_t *data, size_t size)
{
    rrr_hil_frame f;
    memset(&f, 0, sizeof f);
    if (size >= 4u) {
        f.id = (uint32_t)(data[1] | ((uint32_t)data[2] << 8)) & 0x7FFu;
        f.extended = (data[0] >> 1) & 1u;
        f.dlc = data[3]; /* may exceed 8: must be refused, not read */
        const size_t n = size - 4u < 8u ? size - 4u : 8u;
        memcpy(f.data, data + 4, n);
    }
    rrr_hil_msg m;
    m.kind = RRR_HIL_KIND_COUNT; /* not written for an unknown id */
    const rrr_hil_rx rx = rrr_hil_decode(&f, &m);
    if (rx == RRR_HIL_RX_OK && m.kind == RRR_HIL_VOLTAGE_CMD) {
        /* a decoded command re-encodes to the same signal bits (bits 14, 15 are unused) */
        rrr_hil_frame g;
        if (rrr_hil_encode_voltage_cmd(&m.u.cmd, &g) != 0 ||
            ((g.data[1] ^ f.data[1]) & 0x3Fu) != 0u || memcmp(g.data + 2, f.data + 2, 6) != 0) {
            __builtin_trap();
        }
    }
    if (rx == RRR_HIL_RX_OK && m.kind == RRR_HIL_STOP_CMD) {
        /* a decoded stop request re-encodes to the very same two bytes */
        rrr_hil_frame g;
        if (rrr_hil_encode_stop_cmd(&m.u.stop, &g) != 0 || g.dlc != 2u ||
            memcmp(g.data, f.data, 2) != 0) {
            __builtin_trap();
        }
    }
    rrr_hil_sup s;
    const rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
    (void)rrr_hil_sup_init(&s, &cfg);
    const int ok = rx == RRR_HIL_RX_OK;
    if (m.kind == RRR_HIL_VOLTAGE_CMD && rx != RRR_HIL_RX_UNKNOWN_ID) {
        rrr_hil_sup_on_command(&s, rx, ok ? &m.u.cmd : NULL);
    }
    if (m.kind == RRR_HIL_STOP_CMD && rx != RRR_HIL_RX_UNKNOWN_ID &&
        rrr_hil_sup_on_stop(&s, rx, ok ? &m.u.stop : NULL) != 0) {
        __builtin_trap(); /* no command before it: nothing to check its counter against */
    }
    double u[3];
    (void)rrr_hil_sup_next_period(&s, u);
    (void)rrr_hil_rx_str(rx);
}

/* The last valid commands since the latest new fault (the reset must be the last ones). */
typedef struct history {
    unsigned n;
    rrr_hil_voltage_cmd c[RRR_HIL_RESET_ENABLE_FRAMES + 1u];
} history;

static void remember(history *h, const rrr_hil_voltage_cmd *c)
{
    const unsigned cap = RRR_HIL_RESET_ENABLE_FRAMES + 1u;
    if (h->n == cap) {
        memmove(h->c, h->c + 1, (cap - 1u) * sizeof h->c[0]);
        --h->n;
    }
    h->c[h->n++] = *c;
}

/* A latch may clear only after: request, then the enabling commands, counters +1 each. */
static int reset_allowed(const history *h)
{
    if (h->n != RRR_HIL_RESET_ENABLE_FRAMES + 1u || !h->c[0].reset_fault || h->c[0].enable) {
        return 0;
    }
    for (unsigned i = 1; i < h->n; ++i) {
        if (!h->c[i].enable || h->c[i].reset_fault ||
            ((h->c[i].counter - h->c[i - 1u].counter) & 15u) != 1u) {
            return 0;
        }
    }
    return 1;
}

static void sequence(const uint8_t *data, size_t size)
{
    rrr_hil_sup s;
    const rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
    (void)rrr_hil_sup_init(&s, &cfg);
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_BUS);
    history h = {0};
    for (size_t at = 1; at + 12u <= size; at += 12u) {
        const uint8_t *r = data + at;
        const uint8_t op = r[0];
        const uint8_t faults_before = s.faults;
        if ((op & 3u) == 3u) {
            rrr_hil_sup_raise(&s, (op & 4u) ? RRR_HIL_FAULT_SYNC : RRR_HIL_FAULT_BUS);
            h.n = 0;
            continue;
        }
        if ((op & 3u) != 2u) {
            rrr_hil_frame f;
            memset(&f, 0, sizeof f);
            f.id = (uint32_t)(r[1] | ((uint32_t)r[2] << 8)) & 0x7FFu;
            if (op & 0x10u) {
                f.id = RRR_BENCH_VOLTAGE_CMD_FRAME_ID;
            } else if (op & 0x20u) {
                f.id = RRR_BENCH_STOP_CMD_FRAME_ID;
            }
            f.dlc = r[3] & 15u;
            memcpy(f.data, r + 4, 8);
            if ((op & 0x40u) && f.id == RRR_BENCH_VOLTAGE_CMD_FRAME_ID) {
                f.data[0] = rrr_hil_crc8_e2e(f.data + 1, 7, RRR_HIL_DATA_ID_VOLTAGE_CMD);
            } else if ((op & 0x40u) && f.id == RRR_BENCH_STOP_CMD_FRAME_ID) {
                f.data[0] = rrr_hil_crc8_e2e(f.data + 1, 1, RRR_HIL_DATA_ID_STOP_CMD);
            }
            rrr_hil_msg m;
            m.kind = RRR_HIL_KIND_COUNT;
            const rrr_hil_rx rx = rrr_hil_decode(&f, &m);
            const int ok = rx == RRR_HIL_RX_OK;
            if (m.kind == RRR_HIL_VOLTAGE_CMD && rx != RRR_HIL_RX_UNKNOWN_ID) {
                const uint32_t events = s.err.fault_events;
                rrr_hil_sup_on_command(&s, rx, ok ? &m.u.cmd : NULL);
                if (s.err.fault_events != events) {
                    h.n = 0; /* a fault event (this frame rejected): a reset starts over */
                } else if (ok && !s.stop) {
                    remember(&h, &m.u.cmd);
                }
                if (faults_before != 0u && s.faults == 0u && !reset_allowed(&h)) {
                    __builtin_trap(); /* cleared without the whole sequence */
                }
            } else if (m.kind == RRR_HIL_STOP_CMD && rx != RRR_HIL_RX_UNKNOWN_ID) {
                const int honoured = rrr_hil_sup_on_stop(&s, rx, ok ? &m.u.stop : NULL);
                if (honoured && !s.stop) {
                    __builtin_trap();
                }
            }
            if (faults_before != 0u && s.faults == 0u && h.n == 0u) {
                __builtin_trap(); /* nothing but a command may clear a latch */
            }
            if ((op & 3u) == 0u) {
                continue;
            }
        }
        double u[3] = {1.0, 1.0, 1.0};
        const int forced = s.faults != 0u || s.stop;
        const uint32_t events = s.err.fault_events;
        const int zero = rrr_hil_sup_next_period(&s, u);
        if ((s.faults != 0u || s.stop || forced) && (zero != 1 || u[0] != 0.0 || u[1] != 0.0 ||
                                                     u[2] != 0.0)) {
            __builtin_trap(); /* a latched fault or a stop always means 0 V */
        }
        if (s.err.fault_events != events) {
            h.n = 0; /* the timeout latched */
        }
    }
}

/* One read() from a raw CAN socket. */
static void one_read(const uint8_t *data, size_t size)
{
    unsigned char wire[RRR_HIL_SC_WIRE_MAX + 8u];
    memset(wire, 0, sizeof wire);
    const size_t n = size - 1u > sizeof wire ? sizeof wire : size - 1u;
    memcpy(wire, data + 1, n);
    const int can_fd = (data[0] >> 1) & 1u;
    rrr_hil_frame f, g;
    int brs = 0, brs2 = 0;
    if (rrr_hil_sc_from_wire(wire, (long)n, can_fd, &f, &brs) != RRR_HIL_SC_FRAME) {
        return;
    }
    unsigned char back[RRR_HIL_SC_WIRE_MAX];
    const unsigned m = rrr_hil_sc_to_wire(&f, can_fd, brs, back);
    if (f.dlc > 8u || m != (unsigned)n ||
        rrr_hil_sc_from_wire(back, (long)m, can_fd, &g, &brs2) != RRR_HIL_SC_FRAME ||
        memcmp(&f, &g, sizeof f) != 0 || brs != brs2) {
        __builtin_trap();
    }
    rrr_hil_msg msg;
    (void)rrr_hil_decode(&f, &msg);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1u) {
        return 0;
    }
    if ((data[0] & 1u) != 0u) {
        rrr_hil_frame f;
        char word[16];
        const unsigned n = size - 1u > 512u ? 512u : (unsigned)(size - 1u);
        (void)rrr_hil_scd_parse((const char *)data + 1, n, &f, word);
    } else if ((data[0] & 4u) != 0u) {
        sequence(data, size);
    } else if ((data[0] & 8u) != 0u) {
        one_read(data, size);
    } else {
        one_frame(data, size);
    }
    return 0;
}
