/**
 * @file hil_canopen.h
 * @brief A CANopen slave (CiA 301) with the CiA 402 drive profile in cyclic synchronous torque
 *        mode, for one axis: the node that the plant serves three of with `--profile canopen`
 *        (docs/canopen.md). It serves the object dictionary of gen/hil_canopen_od_table.[ch],
 *        generated with the EDS python/rrr_robot/data/rrr_cia402.eds by tools/gen_canopen_od.py.
 *
 * What it does:
 * - NMT slave: boot-up message (0x700 + id, 0x00), pre-operational, operational, stopped, reset
 *   node (every value back to its default), reset communication (0x1000..0x1FFF back to their
 *   defaults); an NMT frame must have DLC 2 and address this node or all (0);
 * - heartbeat producer (0x1017, ms; 0: off) and consumer of one node (0x1016 sub 1: node id in
 *   bits 16..23, time in ms in bits 0..15): monitoring starts with the first heartbeat seen and
 *   its loss is a fault (EMCY 0x8130);
 * - SDO server (0x600 + id -> 0x580 + id, DLC 8): expedited and segmented upload and download,
 *   the standard abort codes (RRR_CO_ABORT_*); in pre-operational and operational only; a
 *   segmented transfer whose client sends no request for RRR_CO_SDO_TIMEOUT_US (rrr_co_advance's
 *   time) is aborted by the server with 0x05040000 (SDO protocol timed out, err.sdo_timeouts);
 * - SYNC consumer (0x1005): on each SYNC in operational, the RPDO received since the last SYNC
 *   is applied (transmission types 0..240; 254/255 apply at once); then rrr_co_transmit sends
 *   the TPDOs whose transmission type n divides the SYNC count, with the state sampled then (the
 *   caller first moves its plant by the period the SYNC closes: see rrr_co_transmit);
 * - PDO mapping readable and writable by SDO, in CiA 301's order (COB-ID bit 31 = 1, sub 0 = 0,
 *   the entries, sub 0 = n, COB-ID bit 31 = 0), checked (mappable, direction, length <= 64 bits);
 *   the COB-IDs by CiA 301's rules (abort 0x06090030): no valid PDO on a restricted identifier
 *   (rrr_co_restricted_id), the identifier changed only while the PDO is invalid, 11 bits only;
 * - the CiA 402 state machine on the controlword 0x6040 / statusword 0x6041 (shutdown, switch
 *   on, enable operation, disable operation, quick stop with the quick stop option code 0x605A,
 *   disable voltage, fault, fault reset on the rising edge of bit 7), halt (bit 8: 0 torque,
 *   the state kept); the option codes 0x605A..0x605E (every stop is 0 torque at once);
 *   homing method 0x6098 = 0 (no homing);
 * - EMCY producer (0x80 + id) with the error register 0x1001 and the error code 0x603F on every
 *   fault, and the error reset EMCY (code 0x0000) on the fault reset.
 * Faults (each latches FAULT, 0 torque, until the 402 fault reset): master heartbeat lost
 * (0x8130), RPDO timeout (no RPDO for 0x2001 SYNC periods in OPERATION ENABLED: 0x8250), NMT
 * state left operational in OPERATION ENABLED (0x8100), a target torque beyond the max torque
 * 0x6072 in an RPDO (0x6320), a simulated fault written to 0x2000 (its code), and
 * rrr_co_raise_fault. The latch and the 0 torque are the bench's rrr_hil_latch
 * (hil_common.h), one per node: a fault latches it with its EMCY code, the 402 fault reset
 * (or a reset node, the application's restart) is its reset event, and rrr_co_torque_Nm is its
 * output stage (0 while latched or in QUICK STOP ACTIVE).
 *
 * Pure logic: no I/O, no allocation, no globals (the table is const); every function is
 * reentrant on distinct nodes. Frames to send are appended to a caller's rrr_co_out.
 */
#ifndef RRR_HIL_CANOPEN_H
#define RRR_HIL_CANOPEN_H

#include <stdint.h>

#include "hil_canopen_od_table.h"
#include "hil_common.h"

/** SDO abort codes (CiA 301). */
#define RRR_CO_ABORT_TOGGLE 0x05030000u        ///< toggle bit not alternated
#define RRR_CO_ABORT_TIMEOUT 0x05040000u       ///< SDO protocol timed out
/** The SDO server's timeout: a segmented transfer idle this long (us) is aborted. */
#define RRR_CO_SDO_TIMEOUT_US 1000000u
#define RRR_CO_ABORT_CS 0x05040001u            ///< command specifier not valid or unknown
#define RRR_CO_ABORT_UNSUPPORTED 0x06010000u   ///< unsupported access to an object
#define RRR_CO_ABORT_WRITE_ONLY 0x06010001u    ///< attempt to read a write-only object
#define RRR_CO_ABORT_READ_ONLY 0x06010002u     ///< attempt to write a read-only object
#define RRR_CO_ABORT_NO_OBJECT 0x06020000u     ///< object does not exist in the dictionary
#define RRR_CO_ABORT_NO_MAP 0x06040041u        ///< object cannot be mapped to the PDO
#define RRR_CO_ABORT_MAP_LEN 0x06040042u       ///< mapped objects would exceed the PDO length
#define RRR_CO_ABORT_LENGTH 0x06070010u        ///< data type length does not match
#define RRR_CO_ABORT_LEN_HIGH 0x06070012u      ///< data type does not match, length too high
#define RRR_CO_ABORT_LEN_LOW 0x06070013u       ///< data type does not match, length too low
#define RRR_CO_ABORT_NO_SUB 0x06090011u        ///< sub-index does not exist
#define RRR_CO_ABORT_VALUE 0x06090030u         ///< invalid value
#define RRR_CO_ABORT_TOO_HIGH 0x06090031u      ///< value too high
#define RRR_CO_ABORT_TOO_LOW 0x06090032u       ///< value too low

/** EMCY error codes the node produces. */
#define RRR_CO_EMCY_RESET 0x0000u          ///< error reset / no error
#define RRR_CO_EMCY_PARAM 0x6320u          ///< parameter error (a target torque out of range)
#define RRR_CO_EMCY_COMM 0x8100u           ///< communication: NMT left operational while enabled
#define RRR_CO_EMCY_HEARTBEAT 0x8130u      ///< life guard / heartbeat error (master lost)
#define RRR_CO_EMCY_PDO_LENGTH 0x8210u     ///< PDO not processed: too short
#define RRR_CO_EMCY_SYNC_LENGTH 0x8240u    ///< unexpected SYNC data length
#define RRR_CO_EMCY_RPDO_TIMEOUT 0x8250u   ///< RPDO timeout

/** Error register (0x1001) bits. */
#define RRR_CO_ERR_GENERIC 0x01u
#define RRR_CO_ERR_COMM 0x10u
#define RRR_CO_ERR_PROFILE 0x20u
#define RRR_CO_ERR_MANUFACTURER 0x80u

/** NMT states (the heartbeat's byte). */
typedef enum rrr_co_nmt {
    RRR_CO_NMT_INIT = 0,          ///< before rrr_co_boot (sends nothing, answers nothing)
    RRR_CO_NMT_STOPPED = 4,
    RRR_CO_NMT_OPERATIONAL = 5,
    RRR_CO_NMT_PREOPERATIONAL = 127
} rrr_co_nmt;

/** CiA 402 states. */
typedef enum rrr_co_402 {
    RRR_CO_402_NOT_READY = 0,      ///< NOT READY TO SWITCH ON
    RRR_CO_402_SWITCH_ON_DISABLED, ///< SWITCH ON DISABLED
    RRR_CO_402_READY,              ///< READY TO SWITCH ON
    RRR_CO_402_SWITCHED_ON,        ///< SWITCHED ON
    RRR_CO_402_OPERATION_ENABLED,  ///< OPERATION ENABLED: the target torque is applied
    RRR_CO_402_QUICK_STOP,         ///< QUICK STOP ACTIVE: 0 torque (quick stop option code 5
                                   ///< or 6; leaves by disable voltage or enable operation)
    RRR_CO_402_FAULT,              ///< FAULT: 0 torque until the fault reset (the fault reaction,
                                   ///< 0 torque, is immediate: FAULT REACTION ACTIVE is never seen)
    RRR_CO_402_COUNT
} rrr_co_402;

/** Quick stop option codes (0x605A) the drive supports; any other value is refused (SDO abort
 *  0x06090030). The drive applies 0 torque at once, so every "ramp" is immediate: 0, 1 and 2
 *  end in SWITCH ON DISABLED at once, 5 and 6 in QUICK STOP ACTIVE. */
enum {
    RRR_CO_QS_DISABLE = 0,          ///< disable drive function: SWITCH ON DISABLED
    RRR_CO_QS_SLOW_DOWN = 1,        ///< slow-down ramp, then SWITCH ON DISABLED
    RRR_CO_QS_QUICK = 2,            ///< quick-stop ramp, then SWITCH ON DISABLED
    RRR_CO_QS_SLOW_DOWN_STAY = 5,   ///< slow-down ramp, stay in QUICK STOP ACTIVE
    RRR_CO_QS_QUICK_STAY = 6        ///< quick-stop ramp, stay in QUICK STOP ACTIVE (the default)
};

/** Controlword bit 8, halt: in OPERATION ENABLED the torque is 0 while it is set (the halt
 *  option code 0x605D, 1 or 2: a ramp, immediate at 0 V), the state stays. */
#define RRR_CO_CW_HALT 0x0100u

/** Frames to send, appended by the node's calls. */
#define RRR_CO_MAX_OUT 8u
typedef struct rrr_co_out {
    unsigned n;                      ///< frames in f
    rrr_hil_frame f[RRR_CO_MAX_OUT]; ///< in the order they are to be sent
} rrr_co_out;

/** Settings of one axis. */
typedef struct rrr_co_config {
    uint8_t node_id;          ///< 1..127
    uint32_t rated_torque_mNm; ///< 0x6076, > 0: the scale of 0x6071 and 0x6077 (per mille)
} rrr_co_config;

/** Event counters (only grow). */
typedef struct rrr_co_err {
    uint32_t sdo_aborts;      ///< SDO aborts sent
    uint32_t nmt_ignored;     ///< NMT frames with a wrong DLC or an unknown command
    uint32_t sync_bad;        ///< SYNC frames with a DLC other than 0 or 1
    uint32_t rpdo_short;      ///< RPDOs shorter than their mapping
    uint32_t hb_lost;         ///< heartbeat consumer timeouts
    uint32_t rpdo_timeouts;   ///< RPDO timeouts
    uint32_t emcy_sent;       ///< EMCY frames sent
    uint32_t out_overflow;    ///< frames dropped: the rrr_co_out was full
    uint32_t sdo_timeouts;    ///< segmented transfers aborted by the server's timeout
} rrr_co_err;

/** One node. Fields are read-only for the caller. */
typedef struct rrr_co_node {
    rrr_co_config cfg;
    uint8_t nmt;                    ///< rrr_co_nmt
    uint8_t s402;                   ///< rrr_co_402
    uint16_t last_cw;               ///< the previous controlword (fault reset edge)
    uint32_t v[RRR_CO_OD_COUNT];    ///< value of every entry (raw bits, zero-extended)
    uint8_t rpdo_pending;           ///< an RPDO arrived since the last SYNC
    uint8_t rpdo_seen;              ///< an RPDO arrived since the last SYNC (timeout count)
    uint8_t rpdo_data[8];           ///< its payload
    unsigned syncs_without_rpdo;    ///< consecutive SYNCs in OPERATION ENABLED without an RPDO
    uint32_t sync_count;            ///< SYNCs seen in operational (TPDO transmission types)
    uint8_t tx_pending;             ///< a SYNC was applied; rrr_co_transmit sends its TPDOs
    uint32_t hb_prod_us;            ///< time since the last heartbeat sent
    uint8_t hb_seen;                ///< consumer: a heartbeat of the monitored node was seen
    uint32_t hb_cons_us;            ///< consumer: time since it
    uint8_t seg_active;             ///< segmented upload in progress
    uint8_t dl_active;              ///< segmented download in progress
    uint8_t seg_toggle;             ///< the transfer's next toggle bit
    uint16_t seg_slot;              ///< its entry
    uint32_t seg_pos;               ///< bytes sent or received
    uint8_t dl_buf[4];              ///< a segmented download's data (writable entries: <= 4 bytes)
    uint32_t sdo_idle_us;           ///< time since the segmented transfer's last request
    double q_rad, qd_rad_s;         ///< feedback set by the plant (sampled at SYNC)
    rrr_hil_latch latch;            ///< the safety policy: latched in FAULT (its code 0x603F);
                                    ///< fault_events: faults latched (one while in FAULT counts
                                    ///< too), resets: FAULT left by the fault reset or a reset
                                    ///< node, zero_periods: SYNC periods in NMT operational with
                                    ///< 0 torque forced (FAULT or QUICK STOP ACTIVE)
    rrr_co_err err;
} rrr_co_node;

/** Settings check and a node in RRR_CO_NMT_INIT; -1 on invalid settings. */
int rrr_co_init(rrr_co_node *n, const rrr_co_config *cfg);

/** Power on: reset node (every value at its default, SWITCH ON DISABLED), the boot-up message,
 *  pre-operational. */
void rrr_co_boot(rrr_co_node *n, rrr_co_out *out);

/** One received frame (any id: those not for this node are ignored). */
void rrr_co_on_frame(rrr_co_node *n, const rrr_hil_frame *f, rrr_co_out *out);

/** After a SYNC was fed to rrr_co_on_frame: sample the feedback (position, velocity, the torque
 *  applied) and send the TPDOs due at that SYNC. A simulated plant steps between the two calls
 *  (the period the SYNC closes, with the torque the SYNC applied), so the TPDOs carry the state
 *  at the end of that period; without a pending SYNC (or outside operational) it sends nothing. */
void rrr_co_transmit(rrr_co_node *n, rrr_co_out *out);

/** Time passes: heartbeat producer and consumer. */
void rrr_co_advance(rrr_co_node *n, uint32_t dt_us, rrr_co_out *out);

/** The plant's joint position (rad) and velocity (rad/s), sent at the next SYNC. */
void rrr_co_set_feedback(rrr_co_node *n, double q_rad, double qd_rad_s);

/** The torque to apply now, N m: the target torque in OPERATION ENABLED and NMT operational
 *  without the halt bit, 0 otherwise, through the output stage of the node's latch (0 while a fault is latched or in
 *  QUICK STOP ACTIVE). */
double rrr_co_torque_Nm(const rrr_co_node *n);

/** Latch a fault from outside (e.g. the bus is lost): FAULT, 0x1001 |= reg_bits | generic,
 *  0x603F = code, an EMCY. */
void rrr_co_raise_fault(rrr_co_node *n, uint16_t code, uint8_t reg_bits, rrr_co_out *out);

/** The statusword of a state (bit 4 voltage enabled, bit 9 remote). */
uint16_t rrr_co_statusword(rrr_co_402 s);

/** Name of a 402 state as canopen.BaseNode402 spells it ("OPERATION ENABLED"). */
const char *rrr_co_402_str(rrr_co_402 s);

/** 1 if no PDO of these drives may be valid on the 11-bit CAN-ID @p can_id (an SDO write of such
 *  a COB-ID is aborted with 0x06090030): CiA 301's restricted CAN-IDs (0x000, 0x001..0x07F,
 *  0x101..0x180, 0x581..0x5FF, 0x601..0x67F, 0x6E0..0x6FF, 0x701..0x7FF) and the predefined
 *  connection set's SYNC 0x080, EMCY 0x081..0x0FF and TIME 0x100; 1 for anything above 0x7FF. */
int rrr_co_restricted_id(uint32_t can_id);

/** Row of (index, sub) in rrr_co_od: >= 0; -1 no such object; -2 no such sub-index. */
int rrr_co_od_find(uint16_t index, uint8_t sub);

/** Position in increments (0x6064) and velocity in increments/s (0x606C) of q (rad) and qd
 *  (rad/s): round(x * increments / 2 pi), saturated to int32. */
int32_t rrr_co_rad_to_inc(double x, uint32_t increments);
/** The @p size (1..4) low bytes of @p v at @p p, little-endian (CANopen's byte order). */
void rrr_co_put_le(uint8_t *p, uint32_t v, unsigned size);
/** @p size (1..4) little-endian bytes at @p p, zero-extended. */
uint32_t rrr_co_get_le(const uint8_t *p, unsigned size);

#endif /* RRR_HIL_CANOPEN_H */
