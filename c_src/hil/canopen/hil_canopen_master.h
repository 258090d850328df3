/**
 * @file hil_canopen_master.h
 * The frames of a CANopen (CiA 301) master of the simulated CiA 402 drives (docs/canopen.md):
 * NMT, SYNC, expedited SDO requests and their answers, the RPDO1 of a drive (controlword and
 * target torque) and its TPDO1/TPDO2 (statusword, position, velocity). Pure functions: no I/O,
 * no allocation, no state; the controller node (rrr_hil_controller --profile canopen) does the
 * sequencing and the I/O.
 */
#ifndef RRR_HIL_CANOPEN_MASTER_H
#define RRR_HIL_CANOPEN_MASTER_H

#include <stdint.h>

#include "hil_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** NMT commands (CiA 301). */
#define RRR_COM_NMT_START 0x01u
#define RRR_COM_NMT_STOP 0x02u
#define RRR_COM_NMT_PREOP 0x80u
#define RRR_COM_NMT_RESET_NODE 0x81u
#define RRR_COM_NMT_RESET_COMM 0x82u

/** The CiA 402 mode "cyclic synchronous torque" (0x6060). */
#define RRR_COM_MODE_CST 10

/** An NMT command to @p node (0: all nodes). */
void rrr_com_nmt(uint8_t command, uint8_t node, rrr_hil_frame *f);
/** A SYNC without counter (DLC 0). */
void rrr_com_sync(rrr_hil_frame *f);

/** The master's own node id in real time (its heartbeat 0x700 + id), its heartbeat producer
 *  period and the consumer time it writes to each drive's 0x1016 sub 1 (ms). */
#define RRR_COM_MASTER_ID 0x7Fu
#define RRR_COM_HEARTBEAT_MS 20u
#define RRR_COM_CONSUMER_MS 100u
/** A heartbeat of @p node (0x700 + node, DLC 1) in NMT state @p state (0x05: operational). */
void rrr_com_heartbeat(uint8_t node, uint8_t state, rrr_hil_frame *f);
/** An expedited SDO download of @p size (1, 2 or 4) bytes of @p value to node:index.sub.
 *  0, or -1 for a size other than 1, 2, 4 or a node outside 1..127. */
int rrr_com_sdo_download(uint8_t node, uint16_t index, uint8_t sub, uint32_t value,
                         unsigned size, rrr_hil_frame *f);
/** An SDO upload request of node:index.sub. 0, or -1 for a node outside 1..127. */
int rrr_com_sdo_upload(uint8_t node, uint16_t index, uint8_t sub, rrr_hil_frame *f);

/** What an SDO server's frame says about the request (node, index, sub). */
typedef enum rrr_com_sdo_answer {
    RRR_COM_SDO_OTHER = 0,   ///< not an SDO answer of that node to that object
    RRR_COM_SDO_DONE = 1,    ///< download confirmed, or expedited upload with the value
    RRR_COM_SDO_ABORT = 2,   ///< abort transfer, with its code
    RRR_COM_SDO_BAD = 3,     ///< an answer to that object this master cannot use (segmented
                             ///< upload, wrong length, an unknown command specifier)
} rrr_com_sdo_answer;

/** Classify @p f as the answer to an expedited download (upload = 0) or upload (upload = 1) of
 *  node:index.sub; the uploaded value (zero-extended) or the abort code in *value. */
rrr_com_sdo_answer rrr_com_sdo_reply(const rrr_hil_frame *f, uint8_t node, uint16_t index,
                                     uint8_t sub, int upload, uint32_t *value);

/** The RPDO1 of @p node: controlword and target torque 0x6071 (per mille of 0x6076). */
void rrr_com_rpdo1(uint8_t node, uint16_t controlword, int16_t torque_pm, rrr_hil_frame *f);

/** A drive's feedback of one SYNC. */
typedef struct rrr_com_feedback {
    uint16_t statusword;
    int32_t position_inc;  ///< 0x6064
    int32_t velocity_inc;  ///< 0x606C, increments per second
    uint8_t have;          ///< bit 0: TPDO1 seen, bit 1: TPDO2 seen
} rrr_com_feedback;

/** The lengths of the drives' default TPDOs: TPDO1 statusword, position actual value, modes of
 *  operation display (2 + 4 + 1 bytes); TPDO2 velocity and torque actual values (4 + 2). */
#define RRR_COM_TPDO1_DLC 7u
#define RRR_COM_TPDO2_DLC 6u

/** Feed @p f: 1 if it is TPDO1 or TPDO2 of @p node (stored into *fb), -1 if it is one with a
 *  DLC other than its mapping's (RRR_COM_TPDO1_DLC, RRR_COM_TPDO2_DLC), 0 otherwise. */
int rrr_com_tpdo(const rrr_hil_frame *f, uint8_t node, rrr_com_feedback *fb);

/** The node of an EMCY frame (COB 0x081..0x0FF with 8 bytes), its error code in *code; 0 if
 *  @p f is no EMCY. */
uint8_t rrr_com_emcy(const rrr_hil_frame *f, uint16_t *code);

/** Which TPDO of @p node @p f is by its COB-ID, whatever its length: 1 (TPDO1, 0x180 + node),
 *  2 (TPDO2, 0x280 + node), 0 neither. */
unsigned rrr_com_tpdo_number(const rrr_hil_frame *f, uint8_t node);

/** A voltage as target torque: tau = k_t u (N m) in per mille of the rated torque (mN m),
 *  rounded half away from zero, within -1000..1000 (0 for a non-finite value). */
int16_t rrr_com_torque_pm(double u_V, double kt, uint32_t rated_mNm);
/** Increments (per s) as rad (rad/s): n 2 pi / increments. */
double rrr_com_inc_to_rad(int32_t n, uint32_t increments);

#ifdef __cplusplus
}
#endif

#endif
