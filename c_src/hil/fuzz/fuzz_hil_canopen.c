/*
 * Fuzz target of the CANopen slave (hil_canopen.h): a sequence of frames and time steps fed to
 * one booted node, with its invariants checked after every step (a violation traps):
 *  - a call never appends more than RRR_CO_MAX_OUT frames, none with a DLC above 8;
 *  - the statusword is that of the 402 state; the mode is CST;
 *  - torque only in NMT operational and OPERATION ENABLED without the halt bit, and never
 *    beyond the max torque 0x6072 (per mille of the rated torque);
 *  - FAULT has the error register's generic bit set; the error register is 0 outside FAULT
 *    (every fault goes to FAULT, only the fault reset clears it); the safety policy's latch
 *    (rrr_hil_latch) is set exactly in FAULT, with the code 0x603F;
 *  - the PDO mappings never exceed 64 bits nor RRR_CO_MAX_MAPPED entries; a valid PDO's COB-ID
 *    is never a restricted identifier (rrr_co_restricted_id) nor a 29-bit one.
 *
 * Input layout: byte 0: the node id (1..127, from byte 0 % 127 + 1); then 12-byte records: op,
 * id low, dlc, data[8], dt. op & 7 chooses the identifier's base (0 NMT, 1 SYNC, 2 SDO request,
 * 3 RPDO1, 4 master heartbeat 0x77F, 5 EMCY range, 6 raw: id low | (op & 0x70) << 4, 7 SDO of
 * another node) plus the node id where CANopen adds it; op & 0x80: a time step of dt ms first.
 * The dlc byte is taken as is (values above 8 must be refused by the caller's transport; here
 * they are clamped to 8, as a transport delivers).
 *
 * rrr_hil_canopen_fuzz_one returns what the sequence reached (bit 0 torque applied, 1 FAULT, 2 a
 * fault reset, 3 a segmented transfer under way), so that its random driver can check depth.
 *
 * libFuzzer (clang):  cmake -DRRR_HIL_FUZZ=ON -DCMAKE_C_COMPILER=clang ...; ./fuzz_hil_canopen
 * Without clang, tests/c/test_hil_canopen.c drives the same function with random inputs.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "hil_canopen.h"

int rrr_hil_canopen_fuzz_one(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(const rrr_co_node *n, const rrr_co_out *out)
{
    if (out->n > RRR_CO_MAX_OUT) {
        __builtin_trap();
    }
    for (unsigned i = 0; i < out->n; ++i) {
        if (out->f[i].dlc > 8u || out->f[i].id > 0x7FFu) {
            __builtin_trap();
        }
    }
    if (n->v[RRR_CO_OD_STATUSWORD] != rrr_co_statusword((rrr_co_402)n->s402) ||
        n->v[RRR_CO_OD_MODE] != (uint32_t)RRR_CO_MODE_CST) {
        __builtin_trap();
    }
    const double tau = rrr_co_torque_Nm(n);
    /* never beyond the max torque 0x6072 (per mille of the rated torque 0x6076) */
    const double rated = (double)n->v[RRR_CO_OD_RATED_TORQUE] * 1e-6 *
                         (double)n->v[RRR_CO_OD_MAX_TORQUE];
    if (tau != 0.0 && (n->nmt != RRR_CO_NMT_OPERATIONAL ||
                       n->s402 != RRR_CO_402_OPERATION_ENABLED ||
                       (n->v[RRR_CO_OD_CONTROLWORD] & RRR_CO_CW_HALT))) {
        __builtin_trap();
    }
    if (!(fabs(tau) <= rated * (1.0 + 1e-12))) {
        __builtin_trap();
    }
    /* the latch of the safety policy is set exactly in FAULT, with the code 0x603F */
    if ((n->s402 == RRR_CO_402_FAULT) != (n->latch.latched != 0u) ||
        (n->latch.latched && n->latch.code != n->v[RRR_CO_OD_ERROR_CODE])) {
        __builtin_trap();
    }
    const uint32_t reg = n->v[RRR_CO_OD_ERROR_REGISTER];
    if ((n->s402 == RRR_CO_402_FAULT) != (reg != 0u) ||
        (n->s402 == RRR_CO_402_FAULT && !(reg & RRR_CO_ERR_GENERIC))) {
        __builtin_trap();
    }
    static const int maps[3] = {RRR_CO_OD_RPDO1_MAP_N, RRR_CO_OD_TPDO1_MAP_N,
                                RRR_CO_OD_TPDO2_MAP_N};
    static const int cobs[3] = {RRR_CO_OD_RPDO1_COBID, RRR_CO_OD_TPDO1_COBID,
                                RRR_CO_OD_TPDO2_COBID};
    for (int m = 0; m < 3; ++m) {
        /* a valid PDO is never on a restricted identifier; never a 29-bit one */
        const uint32_t cob = n->v[cobs[m]];
        if ((cob & 0x3FFFF800u) != 0u ||
            (!(cob & 0x80000000u) && rrr_co_restricted_id(cob & 0x7FFu))) {
            __builtin_trap();
        }
        const uint32_t cnt = n->v[maps[m]];
        if (cnt > RRR_CO_MAX_MAPPED) {
            __builtin_trap();
        }
        uint32_t bits = 0;
        for (uint32_t i = 1; i <= cnt; ++i) {
            bits += n->v[maps[m] + (int)i] & 0xFFu;
        }
        if (bits > 64u) {
            __builtin_trap();
        }
    }
}

int rrr_hil_canopen_fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1u) {
        return 0;
    }
    const uint8_t id = (uint8_t)(data[0] % 127u + 1u);
    rrr_co_node n;
    const rrr_co_config cfg = {id, 120000u};
    if (rrr_co_init(&n, &cfg) != 0) {
        __builtin_trap();
    }
    rrr_co_out out = {0};
    rrr_co_boot(&n, &out);
    check(&n, &out);
    int reached = 0;
    static const uint32_t base[8] = {0x000u, 0x080u, 0x600u, 0x200u, 0x77Fu, 0x080u, 0u, 0x600u};
    for (size_t at = 1; at + 12u <= size; at += 12u) {
        const uint8_t *r = data + at;
        const uint8_t op = r[0];
        if (op & 0x80u) {
            out.n = 0;
            rrr_co_advance(&n, (uint32_t)r[11] * 1000u, &out);
            check(&n, &out);
        }
        rrr_hil_frame f;
        memset(&f, 0, sizeof f);
        const unsigned kind = op & 7u;
        if (kind == 6u) {
            f.id = (uint32_t)r[1] | ((uint32_t)(op & 0x70u) << 4);
        } else {
            const uint32_t add = kind == 2u || kind == 3u || kind == 5u ? id
                                 : kind == 7u ? (uint32_t)((id % 127u) + 1u) : 0u;
            f.id = base[kind] + add;
        }
        f.dlc = r[2] > 8u ? 8u : r[2];
        memcpy(f.data, r + 3, f.dlc);
        out.n = 0;
        rrr_co_on_frame(&n, &f, &out);
        rrr_co_set_feedback(&n, (double)(int8_t)r[11] * 0.1, (double)(int8_t)r[10]);
        rrr_co_transmit(&n, &out);
        check(&n, &out);
        reached |= (rrr_co_torque_Nm(&n) != 0.0 ? 1 : 0) | (n.s402 == RRR_CO_402_FAULT ? 2 : 0) |
                   (n.latch.resets ? 4 : 0) | (n.dl_active || n.seg_active ? 8 : 0);
    }
    return reached;
}

#ifdef RRR_HIL_LIBFUZZER
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    (void)rrr_hil_canopen_fuzz_one(data, size);
    return 0;
}
#endif
