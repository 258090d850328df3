/* What the FMI 2 and FMI 3 harnesses (test_fmu_harness.c, test_fmu3_harness.c) share beyond the
 * importer (c_src/fmi_import): the model parameters by FMU variable name, the log sink, the
 * closed loop along the reference, the start-value checks, the FMU state replays and refusals,
 * the forged states and the two-instance test. They run through an adapter (fh_ops) that each
 * harness fills with its version's calls; what differs between FMI 2 and FMI 3 stays in the
 * harnesses. Compiled once (fmu_harness_common.c) into each harness. */
#ifndef FMU_HARNESS_COMMON_H
#define FMU_HARNESS_COMMON_H

#include <stddef.h>

#include "fmu_state_forge.h"
#include "rrr/rrr.h"
#include "rrr_fmi_import.h"

#define FH_H 1e-3 /* communication step of the closed loop, s */

/* Statuses as both versions number them (fmi2Status and fmi3Status agree up to Fatal). */
enum { FH_OK = 0, FH_WARNING = 1, FH_DISCARD = 2, FH_ERROR = 3, FH_FATAL = 4, FH_NSTATUS = 6 };

/* ---- the model parameters, named as in both FMUs -------------------------------------------- */

/* Every parameter of rrr_model with its FMU variable name. */
#define N_MODEL_PARAMS (6 + RRR_NP + 3 + 9 + 9 + 3 + 1)

void fh_model_params(const rrr_model *m, char names_[N_MODEL_PARAMS][16],
                     double values[N_MODEL_PARAMS]);

/* ---- an FMU: modelDescription.xml and binary, through c_src/fmi_import ---------------------- */

/* Loads dir's modelDescription.xml (which must be FMI version fmi), copies its modelIdentifier
 * and token (guid), opens binaries/<platform>/<id>.so. 0 when done, else 1 with a message. */
int fh_open(rrr_fmi_md *md, rrr_fmi_lib *lib, const char *dir, int fmi, char id[64],
            char token[128]);
void fh_close(rrr_fmi_md *md, rrr_fmi_lib *lib);

/* Value reference of a variable; aborts the run (exit 2) when it is missing. */
unsigned int fh_md_vr(const rrr_fmi_md *md, const char *name);

/* ---- what an instance logs ------------------------------------------------------------------ */

typedef struct fh_log_sink {
    int count[FH_NSTATUS]; /* messages per status */
    int illegal;           /* messages that report an illegal call sequence */
    int not_provided;      /* messages that report a function that is not provided */
    int calls;             /* messages of category logCalls */
    char last[1024];       /* the last message */
    char last_error[1024]; /* the last message with status >= Error */
} fh_log_sink;

/* Counts s->last (already written) as a message of status and category. */
void fh_log_record(fh_log_sink *s, int status, const char *category);

/* ---- the adapter: one FMI version's calls on a harness instance (void *x) -------------------- */

typedef struct fh_ops {
    const char *fmi;         /* "fmi2" or "fmi3": the prefix of the version's functions */
    const char *set_real_name; /* "fmi2SetReal", "fmi3SetFloat64": named by its refusals */
    int step_reports_time;   /* do_step returns lastSuccessfulTime (FMI 3) */
    const void *(*api)(const void *x);            /* the FMU of instance x */
    const char *(*id)(const void *api);           /* its modelIdentifier */
    const rrr_fmi_md *(*md)(const void *api);     /* its modelDescription.xml */
    const char *(*where)(const void *x);          /* interface type, for messages */
    fh_log_sink *(*log)(void *x);
    /* a new Co-Simulation instance (malloc'd; NULL on failure) and its end */
    void *(*new_cs)(const void *api, const char *name);
    void (*del)(void *x);
    int (*drive_init)(void *x); /* a fresh instance into initialization mode: 0 when done */
    int (*drive_step)(void *x); /* a fresh instance stepping (one step taken): 0 when done */
    /* checks that x is stepping (discarded: after a discarded step), by the harness's means */
    void (*check_stepping)(void *x, int discarded, const char *where);
    /* the calls; each returns the status */
    int (*get_real)(void *x, const unsigned int *vr, size_t n, double *v);
    int (*set_real)(void *x, const unsigned int *vr, size_t n, const double *v);
    int (*get_bool)(void *x, unsigned int vr, int *v);
    int (*set_bool)(void *x, unsigned int vr, int v);
    int (*setup)(void *x); /* fmi2SetupExperiment; NULL for FMI 3 */
    int (*enter_init)(void *x);
    int (*exit_init)(void *x);
    int (*do_step)(void *x, double t, double h, double *last_time);
    int (*terminate)(void *x);
    int (*reset)(void *x);
    int (*get_state)(void *x, void **s);
    int (*set_state)(void *x, void *s);
    int (*free_state)(void *x, void **s);
    int (*state_size)(void *x, void *s, size_t *n);
    int (*serialize)(void *x, void *s, unsigned char *buf, size_t n);
    int (*deserialize)(void *x, const unsigned char *buf, size_t n, void **s);
} fh_ops;

/* Value references of three joint variables, e.g. "q" -> q[1], q[2], q[3]. */
void fh_vrs3(const fh_ops *ops, const void *api, const char *base, unsigned int vr[3]);
/* The same for n bases in a row: vr[3 * n]. */
void fh_vrs(const fh_ops *ops, const void *api, const char *const *bases, size_t n,
            unsigned int *vr);
/* The controller's 15 inputs in their order: q_ref, qd_ref, qdd_ref, q, qd. */
extern const char *const fh_ctrl_inputs[5];
double fh_get1(const fh_ops *ops, void *x, const char *name);
int fh_set1(const fh_ops *ops, void *x, const char *name, double v);

/* 1 when msg names word as a whole word (e.g. "fmi3GetInt8", "StepMode"). */
int fh_names_word(const char *msg, const char *word);

/* One refused call: Error, exactly one error message, holding every needle (NULL: none). */
void fh_expect_error(const fh_ops *ops, void *x, int st, const char *what, const char *n1,
                     const char *n2);

/* A refused set of one real variable: Error, exactly one error message naming the variable's
 * needle and set_real_name, the old value kept. */
void fh_expect_refused(const fh_ops *ops, void *x, const char *name, double v, const char *needle);

/* A refused call that writes outputs (out[n], filled with FH_UNTOUCHED before the call): Error,
 * exactly one error message holding needle, out untouched. */
#define FH_UNTOUCHED 42.0
void fh_expect_refused_out(const fh_ops *ops, void *x, int st, const char *what,
                           const char *needle, const double *out, size_t n);

/* The macro that writes a harness's table of callers: call_NAME(x) calls NAME with valid
 * arguments on x (status type S, FMU type API). */
#define FH_CALLER(S, API, NAME, ...)                                                          \
    static S call_##NAME(inst *x)                                                             \
    {                                                                                         \
        const API *a = x->api;                                                                \
        __VA_ARGS__                                                                           \
    }

/* The serialized FMU state of x (malloc'd, *n bytes), or NULL; taking it changes nothing. */
unsigned char *fh_state_bytes(const fh_ops *ops, void *x, size_t *n);

/* ---- start values --------------------------------------------------------------------------- */

/* Value after instantiation (read in initialization mode) = XML start = expected. */
void fh_check_default(const fh_ops *ops, void *x, const char *name, double expected);
/* The same for a Boolean. */
void fh_check_bool_default(const fh_ops *ops, void *x, const char *name, int expected);
/* Every start value of plant p and controller c (both in initialization mode) = librrr's. */
void fh_check_defaults(const fh_ops *ops, void *p, void *c);

/* ---- closed loop: controller -> plant, Gauss-Seidel, 1 kHz ---------------------------------- */

typedef struct fh_loop {
    const fh_ops *ops;
    void *p, *c;
    unsigned int p_u[3], p_q[3], p_qd[3], c_ref[9], c_q[3], c_qd[3], c_u[3];
    double t;
} fh_loop;

void fh_loop_new(fh_loop *L, const fh_ops *ops, void *p, void *c);
/* Instantiated to stepping for both, plant started on the reference. */
int fh_loop_init(fh_loop *L);
/* One macro step; rec (9 values: q, qd, u) may be NULL. */
int fh_loop_step(fh_loop *L, double rec[9]);
/* n steps; the largest |q - q_ref|. */
double fh_loop_run(fh_loop *L, int n, double (*rec)[9]);
/* The closed loop over 1 s from initialization, printed under label and checked (error < 1e-3
 * rad, end time 1 s): 0 when it ran. */
int fh_loop_first(fh_loop *L, double (*rec)[9], const char *label);
/* Again from initialization: the same trajectory as rec, bit for bit. */
void fh_loop_again(fh_loop *L, double (*rec)[9], double (*rec_again)[9]);
/* The closed loop, terminated, reset and run again (fh_loop_first, fh_loop_again), no error or
 * warning logged; after_first and after_reset (may be NULL) add the harness's checks. */
void fh_loop_twice(fh_loop *L, double (*rec)[9], double (*rec_again)[9], const char *label,
                   void (*after_first)(fh_loop *L), void (*after_reset)(fh_loop *L));

/* ---- refused values ------------------------------------------------------------------------- */

/* Plant p and controller c in initialization mode: NaN, Inf and outputs refused. */
void fh_refused_in_init(const fh_ops *ops, void *p, void *c);
/* A multi-value set of the plant's u with one NaN changes nothing. */
void fh_refused_multi(const fh_ops *ops, void *p);
/* Plant p and controller c, in initialization mode after refusals: a good set accepted; then
 * stepping: inputs checked, fixed parameters refused (the message naming fixed_needle). */
void fh_refused_stepping(const fh_ops *ops, void *p, void *c, const char *fixed_needle);
/* After refusals both still step from 0 normally. */
void fh_still_stepping(const fh_ops *ops, void *p, void *c);

/* ---- FMU state ------------------------------------------------------------------------------- */

#define FH_N_REPLAY 300

/* The states of a closed loop's plant and controller saved after 200 steps, and their bytes. */
typedef struct fh_saved {
    void *sp, *sc;
    unsigned char *bp, *bc;
    size_t np, nc;
    double t1;
} fh_saved;

/* Saved after 200 steps; set back and rerun, serialized, deserialized, set and rerun: each
 * rerun bit-identical. after_set (may be NULL) checks the instance after the first set. 0 when
 * done; S then holds the deserialized states and the bytes (fh_saved_free). */
int fh_state_replay(fh_loop *L, fh_saved *S, void (*after_set)(fh_loop *L, double t1));
/* Corrupted, truncated, foreign bytes and NULL states refused (the serialized state of the
 * plant unchanged); a buffer too small refused. */
void fh_state_refusals(fh_loop *L, fh_saved *S);
void fh_saved_free(fh_loop *L, fh_saved *S);
/* The FMU state test's common part on new Co-Simulation instances of plant and ctrl:
 * fh_state_replay, then fh_state_refusals. 0 when done; fh_state_end frees it all. */
int fh_state_begin(const fh_ops *ops, const void *plant, const void *ctrl, fh_loop *L,
                   fh_saved *S, void (*after_set)(fh_loop *L, double t1));
void fh_state_end(fh_loop *L, fh_saved *S);
/* A state saved while stepping brings a discarded step back (a step that cannot be taken:
 * 1e8 substeps of the fixed-step RK4). */
void fh_state_undoes_discard(const fh_ops *ops, const void *plant);

/* Forged FMU states with valid checksums: each refused naming the field, by deserialize and by
 * set, the state of x unchanged; the good bytes accepted, then (step_t >= 0) a step at step_t.
 * adjust (may be NULL) adapts a case to the interface type. */
void fh_forged_states(const fh_ops *ops, void *x, const forge_case *cases, size_t n_cases,
                      size_t data_size, void (*adjust)(forge_case *fc), double step_t);

/* Two instances of one FMU in one process do not share anything. */
void fh_two_instances(const fh_ops *ops, const void *plant);

#endif /* FMU_HARNESS_COMMON_H */
