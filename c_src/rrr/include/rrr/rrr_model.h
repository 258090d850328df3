/**
 * @file rrr_model.h
 * @brief Model parameters of the RRR arm (paper Table I, eqs 8, 9, 12), defaults, validation,
 *        and the base parameter set (eq 12) from full inertial parameters.
 *
 * The model is a plain value type (like pinocchio's Model): every algorithm takes a
 * `const rrr_model *` and writes its results through caller-owned output arrays.
 * Nothing in the core allocates, performs I/O, reads a clock or keeps global state.
 */
#ifndef RRR_MODEL_H
#define RRR_MODEL_H

#ifdef __cplusplus
extern "C" {
#endif

#include "rrr_status.h"

/** Number of base parameters (eq 12). */
#define RRR_NP 16
/** Number of joints. */
#define RRR_NJ 3
/** Number of tanh terms per joint in the friction model (eq 9). */
#define RRR_NF 3

/**
 * @brief Parameters of the RRR arm.
 *
 * Conventions (docs/conventions.md#frames-and-dh-table): standard DH, alpha = (pi/2, 0, 0),
 * a = (0, a2, a3), d = (d1, d2, d3); z0 up, gravity g > 0 along -z0. The base parameters p
 * follow the corrected eq 12 of the paper in its order and signs; the rotor inertias J_m,i are
 * inside p7, p12 and p14, so R(q, qd, qdd) p is the motor torque tau + J_m qdd of eq 8.
 */
typedef struct rrr_model {
    double d1;                     ///< DH link offset of joint 1 (shoulder height), m
    double a2;                     ///< DH link length of link 2 (upper arm), m, > 0
    double a3;                     ///< DH link length of link 3 (forearm), m, > 0
    double d2;                     ///< DH link offset of joint 2, m
    double d3;                     ///< DH link offset of joint 3, m (only d2 + d3 enters kinematics)
    double g;                      ///< gravitational acceleration along -z0, m/s^2, >= 0
    double p[RRR_NP];              ///< base parameters p1..p16 of eq 12 (SI units), p[0] is p1
    double kt[RRR_NJ];             ///< torque constants k_t,i of eq 8, N m / V, > 0
    double f[RRR_NJ][RRR_NF];      ///< friction amplitudes f_ik of eq 9, V
    double w[RRR_NJ][RRR_NF];      ///< friction slopes w_ik of eq 9, s/rad
    double b[RRR_NJ];              ///< viscous friction b_i of eq 9, V s/rad
    double u_max;                  ///< input voltage limit (symmetric), V, > 0
} rrr_model;

/** @brief Mass properties of one link, in its DH frame i (frame i sits at the distal end of link i). */
typedef struct rrr_link_inertia {
    double mass;                   ///< link mass, kg, >= 0
    double com[3];                 ///< centre of mass in DH frame i, m
    double inertia_com[3][3];      ///< inertia TENSOR about the centre of mass, axes of frame i, kg m^2 (symmetric, positive semi-definite)
} rrr_link_inertia;

/** @brief Full inertial description of the arm, from which eq 12 computes p. */
typedef struct rrr_inertial {
    rrr_link_inertia link[RRR_NJ]; ///< links 1..3 (link 1 enters only through its inertia about the joint-1 axis)
    double rotor_inertia[RRR_NJ];  ///< total rotor inertia J_m,i (rotor, encoder, slip rings), kg m^2, >= 0
} rrr_inertial;

/**
 * @brief Fill the default robot (a documented proposal: the paper prints no numbers).
 *
 * Kinematics, gravity, motors, friction and voltage limit as in `python/rrr_robot/data/default_robot.toml`;
 * p is computed from the default inertial parameters by rrr_bps_from_inertia().
 * @param[out] m model to fill (not NULL)
 * @return RRR_OK, or RRR_BAD_INPUT if m is NULL
 */
RRR_API rrr_status rrr_model_default(rrr_model *m);

/**
 * @brief Default inertial parameters (the masses, centres of mass and inertias behind the default p).
 * @param[out] in inertial description to fill (not NULL)
 */
RRR_API rrr_status rrr_inertial_default(rrr_inertial *in);

/**
 * @brief Check a model for use.
 *
 * Rejects a value outside its range in the parameter table (rrr_params.h: non-finite values,
 * a2 <= 0, a3 <= 0, g < 0, k_t <= 0, u_max <= 0, b < 0, w < 0; the first such row is named), and a
 * base parameter vector whose inertia matrix D(q) is not positive definite somewhere: D does
 * not depend on q1, and its smallest Cholesky pivot is checked on a 64 x 64 grid of (q2, q3)
 * and minimised by a pattern search from every grid point lower than its neighbours (so a dip
 * between grid points is found too). Costs about 1 ms.
 * @param[in]  m     model
 * @param[out] field if not NULL, receives a static string naming the offending field (e.g. "kt[1]"),
 *                   or "" when the model is valid
 * @return RRR_OK, RRR_BAD_INPUT (NULL model), RRR_BAD_MODEL (a value out of range) or
 *         RRR_NOT_POSITIVE_DEFINITE (D(q) not positive definite somewhere)
 */
RRR_API rrr_status rrr_model_validate(const rrr_model *m, const char **field);

/**
 * @brief Base parameter set p of eq 12 (corrected: docs/conventions.md#typos-in-the-printed-eq-12) from full inertial parameters.
 *
 * Converts each inertia tensor from the centre of mass to the frame origin O_i by the
 * parallel-axis theorem, takes products of inertia as integrals (I_xy = -tensor[0][1]), and
 * evaluates eq 12 with e = d2 + d3. Uses a2, a3, d2, d3 of @p m; other fields are ignored.
 * @param[in]  m   kinematic parameters
 * @param[in]  in  inertial parameters
 * @param[out] p   the 16 base parameters, p[0] = p1
 * @return RRR_OK, RRR_BAD_INPUT (NULL or non-finite input, negative mass or rotor inertia)
 */
RRR_API rrr_status rrr_bps_from_inertia(const rrr_model *m, const rrr_inertial *in, double p[RRR_NP]);

#ifdef __cplusplus
}
#endif
#endif /* RRR_MODEL_H */
