/**
 * @file hil_controller.h
 * @brief The controller node (rrr_hil_controller.c): its options, the state every bus profile
 *        shares (the model, the reference, the measured state, the log), the law with its log row,
 *        sending and receiving with the reason a run ends, and what a profile provides
 *        (rrr_hil_ctrl_profile: dbc/hil_dbc_controller.c, canopen/hil_canopen_controller.c).
 */
#ifndef RRR_HIL_CONTROLLER_H
#define RRR_HIL_CONTROLLER_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "hil_node.h"
#include "rrr/rrr.h"

/** The controller's command line. */
typedef struct rrr_hil_ctrl_opts {
    rrr_hil_link_opts link; ///< the transport
    const char *ref_path;   ///< --reference REF.csv
    const char *log_path;   ///< --log FILE.csv (NULL: none)
    int realtime;           ///< --realtime
    int timeout_ms;         ///< --timeout-ms: longest wait for the plant (5000)
    rrr_ctc_gains gains;    ///< --kp, --kd, --no-feedforward
    rrr_hil_rt_opts rt;     ///< the real-time options
    const char *sets[64];   ///< "NAME=VALUE" model parameters (--set), applied in order
    int n_sets;             ///< entries in sets
    int profile;            ///< --profile: index in the node's profile table (0: the first, dbc)
    uint8_t node_ids[3];    ///< --node-ids a,b,c (default 1,2,3)
    uint32_t consumer_ms;   ///< --consumer-ms (CANopen, real time): the drives' heartbeat
                            ///< consumer time of the master, ms (0: the profile's default)
    uint32_t rpdo_timeout;  ///< --rpdo-timeout (CANopen, real time): the drives' RPDO timeout
                            ///< 0x2001, SYNC periods (0: the drives' own)
} rrr_hil_ctrl_opts;

/** A law with rrr_ctc's signature (eq 15). */
typedef rrr_status (*rrr_hil_ctc_fn)(const rrr_model *m, const rrr_ctc_gains *gains,
                                     const double q_ref[3], const double qd_ref[3],
                                     const double qdd_ref[3], const double q[3],
                                     const double qd[3], rrr_ctc_output *out);

/** What every profile's controller loop shares. */
typedef struct rrr_hil_ctrl {
    rrr_model model;       ///< the controller's model: the default robot with the --set parameters
    rrr_hil_reference ref; ///< the reference, one row per period
    rrr_hil_transport *tr; ///< the open transport
    double q[3], qd[3];    ///< newest complete measured state, rad, rad/s
    uint32_t states;       ///< complete states received
    uint32_t ctc_failed;   ///< periods in which rrr_ctc failed (0 V commanded)
    FILE *log;             ///< --log (NULL: none)
    rrr_hil_run run;       ///< the period and why the run ends (the exit line)
    rrr_hil_ctc_fn ctc;    ///< the law rrr_hil_ctrl_law evaluates: rrr_ctc when NULL (the
                           ///< firmware, c_src/firmware, puts its timed or single-precision
                           ///< law here)
} rrr_hil_ctrl;

/** What a bus profile provides to the controller node (one row of its profile table). */
typedef struct rrr_hil_ctrl_profile {
    const char *name;  ///< --profile NAME
    const char *usage; ///< its lines of the usage text ("" for none)
    /** The checks of the options that concern the profile, after parsing: 0, or -1 with a
     *  message printed (NULL: none). */
    int (*check)(const rrr_hil_ctrl_opts *o);
    /** The identifiers SocketCAN receives (at most RRR_HIL_CTRL_MAX_RX_IDS): their count. */
    unsigned (*rx_ids)(const rrr_hil_ctrl_opts *o, uint32_t *ids);
    /** The run on the open transport c->tr: the loop, then the frame log closed and the summary
     *  (stdout "RRR_HIL_SUMMARY {json}", after "RRR_HIL_RT {json}" in real time). Owns
     *  @p latency_log (NULL unless --realtime --latency-log). Returns the exit status, with
     *  c->run telling why. */
    int (*run)(rrr_hil_ctrl *c, const rrr_hil_ctrl_opts *o, FILE *latency_log,
               rrr_hil_framelog *frames);
} rrr_hil_ctrl_profile;

/** Most identifiers a profile's rx_ids gives. */
#define RRR_HIL_CTRL_MAX_RX_IDS 32u

/**
 * @brief u_k from the reference row @p k and the measured state (rrr_ctc, eq 15, or c->ctc) with
 *        the --kp/--kd/--no-feedforward gains, and its row of the controller log (--log).
 *        In hil_controller_law.c, which needs no transport: the firmware compiles it too.
 * @param enable 0: 0 V (no law)
 * @param[out] u_V the voltages, V (0 when not enabled or when rrr_ctc failed)
 * @return the enable in effect: @p enable, or 0 when rrr_ctc failed (counted in ctc_failed)
 */
int rrr_hil_ctrl_law(rrr_hil_ctrl *c, const rrr_hil_ctrl_opts *o, size_t k, int enable,
                     double u_V[3]);

/** The plant is lost (RRR_HIL_EXIT_PEER_LOST): "plant lost: WHAT: IO[: transport error]". */
int rrr_hil_ctrl_lost(rrr_hil_ctrl *c, const char *what, rrr_hil_io io);

/** Send one frame: 0, or RRR_HIL_EXIT_PEER_LOST with the reason set (@p what: "send X"). */
int rrr_hil_ctrl_send(rrr_hil_ctrl *c, const rrr_hil_frame *f, const char *what);

/** The next frame before @p deadline_ms (rrr_hil_now_ms), waiting in slices so that SIGINT and
 *  SIGTERM end the wait at once: 0, or an exit status with the reason set ("plant lost: no WHAT
 *  within N ms (--timeout-ms)", interrupted, a transport failure). */
int rrr_hil_ctrl_recv_until(rrr_hil_ctrl *c, int64_t deadline_ms, const rrr_hil_ctrl_opts *o,
                            const char *what, rrr_hil_frame *f);

#endif /* RRR_HIL_CONTROLLER_H */
