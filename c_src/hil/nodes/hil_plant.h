/**
 * @file hil_plant.h
 * @brief The plant node (rrr_hil_plant.c): its options, the state every bus profile shares (the
 *        plant FMU, its state and log, the transport), one period of the FMU, the reasons a run
 *        ends, and what a profile provides (rrr_hil_plant_profile: dbc/hil_dbc_plant.c,
 *        canopen/hil_canopen_plant.c).
 */
#ifndef RRR_HIL_PLANT_H
#define RRR_HIL_PLANT_H

#include <stdint.h>
#include <stdio.h>

#include "hil_fmu.h"
#include "hil_node.h"

#define RRR_HIL_PLANT_MAX_SETS 64

/** The plant's command line. */
typedef struct rrr_hil_plant_opts {
    rrr_hil_link_opts link; ///< the transport
    const char *fmu_dir;    ///< --fmu DIR: the unzipped plant FMU
    const char *log_path;   ///< --log FILE.csv (NULL: none)
    int realtime;           ///< --realtime
    double duration_s;      ///< --duration S (real time)
    double q0[3], qd0[3];   ///< --q0, --qd0
    int have_q0, have_qd0;  ///< given
    const char *set_name[RRR_HIL_PLANT_MAX_SETS]; ///< --set NAME=VALUE: the FMU's parameters
    double set_value[RRR_HIL_PLANT_MAX_SETS];     ///< their values
    int n_set;              ///< entries in set_name
    int max_missed;         ///< --max-missed (the DBC supervisor's), -1: its default
    int max_delta_counter;  ///< --max-delta-counter (the DBC supervisor's), -1: its default
    rrr_hil_rt_opts rt;     ///< the real-time options
    int profile;            ///< --profile: index in the node's profile table (0: the first, dbc)
    uint8_t node_ids[3];    ///< --node-ids a,b,c (default 1,2,3)
    int end_after_stop_ms;  ///< --end-after-stop-ms N (canopen): 0 none
} rrr_hil_plant_opts;

/** What every profile's plant loop shares. */
typedef struct rrr_hil_plant {
    rrr_hil_fmu fmu;
    fmi2ValueReference vr_u[3];
    fmi2ValueReference vr_x[6]; ///< q[1..3], qd[1..3]
    fmi2ValueReference vr_y[6]; ///< qdd[1..3], tip.x, tip.y, tip.z (logged only)
    double x[6];                ///< q, rad, and qd, rad/s
    double y[6];                ///< qdd, rad/s2, and the tip, m
    double u[3];                ///< the voltages applied over the next period, V
    double kt[3];               ///< the FMU's torque constants k_t, N m/V (rrr_hil_plant_read_kt)
    double u_max_V;             ///< the FMU's voltage limit u_max, V (rrr_hil_plant_read_kt)
    rrr_hil_transport *tr;      ///< the open transport
    int started;                ///< the controller's first frame arrived
    int64_t last_rx_ms;         ///< rrr_hil_now_ms of the last frame received
    FILE *log;                  ///< --log (NULL: none)
    uint8_t log_zero;   ///< logged: 0 V forced over the last period
    uint8_t log_faults; ///< logged: latched faults (DBC: RRR_HIL_FAULT_*; CANopen: bit i axis i)
    rrr_hil_run run;    ///< k: periods advanced; why the run ends (the exit line)
} rrr_hil_plant;

/** What a bus profile provides to the plant node (one row of its profile table). */
typedef struct rrr_hil_plant_profile {
    const char *name;  ///< --profile NAME
    const char *usage; ///< its lines of the usage text ("" for none)
    /** The checks of the options that concern the profile, after parsing: 0, or -1 with a
     *  message printed (NULL: none). */
    int (*check)(const rrr_hil_plant_opts *o);
    /** After the FMU is set up, before the log and the transport open: 0, or -1 with a message
     *  printed (NULL: nothing to do). */
    int (*setup)(rrr_hil_plant *p, const rrr_hil_plant_opts *o);
    /** The identifiers SocketCAN receives (at most RRR_HIL_PLANT_MAX_RX_IDS; 0: every one). */
    unsigned (*rx_ids)(const rrr_hil_plant_opts *o, uint32_t *ids);
    /** The run on the open transport p->tr: the loop, then the frame log closed and the summary
     *  (stdout "RRR_HIL_SUMMARY {json}", after "RRR_HIL_RT {json}" in real time). Owns
     *  @p latency_log. Returns the exit status, with p->run telling why. */
    int (*run)(rrr_hil_plant *p, const rrr_hil_plant_opts *o, FILE *latency_log,
               rrr_hil_framelog *frames);
} rrr_hil_plant_profile;

/** Most identifiers a profile's rx_ids gives. */
#define RRR_HIL_PLANT_MAX_RX_IDS 32u

/** Load the FMU of --fmu, the value references, --q0/--qd0/--set, initialise, read the state.
 *  0, or -1 with a message printed. */
int rrr_hil_plant_setup_fmu(rrr_hil_plant *p, const rrr_hil_plant_opts *o);

/** The FMU's torque constants kt[1..3] and its u_max into p->kt and p->u_max_V (for a profile
 *  that commands torques). 0, or -1 with a message printed. */
int rrr_hil_plant_read_kt(rrr_hil_plant *p);

/** The log row of period p->run.k (k, t, q, qd, u, zero, faults, qdd, tip; rrr_hil_logs.h). */
void rrr_hil_plant_log_row(rrr_hil_plant *p);

/** Advance one period with p->u: FMU step, new state, log row. 0, or -1 (RRR_HIL_EXIT_FAULT
 *  with the reason set: the FMU failed). */
int rrr_hil_plant_step(rrr_hil_plant *p);

/** The controller is lost (RRR_HIL_EXIT_PEER_LOST): "controller lost[ before its first frame]:
 *  WHAT" and @p note ("" for none). */
int rrr_hil_plant_lost(rrr_hil_plant *p, const char *what, const char *note);
/** ... for a transport failure: WHAT is "transport IO: the transport's last error". */
int rrr_hil_plant_transport_lost(rrr_hil_plant *p, rrr_hil_io io, const char *note);
/** ... for a silent controller: WHAT is "no frame for N ms (--idle-timeout-ms)". */
int rrr_hil_plant_silence_lost(rrr_hil_plant *p, int idle_ms, const char *note);

#endif /* RRR_HIL_PLANT_H */
