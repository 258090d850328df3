/**
 * @file rrr_kinematics.h
 * @brief Closed-form kinematics of the RRR arm (paper eqs 3-6): FK, Jacobian, IK on every
 *        posture branch valid in the whole workspace, nearest-branch IK with multi-turn
 *        unwrapping, singularity classification.
 */
#ifndef RRR_KINEMATICS_H
#define RRR_KINEMATICS_H

#ifdef __cplusplus
extern "C" {
#endif

#include "rrr_model.h"

/**
 * @brief Posture branches. The shoulder branch is the sign of the planar reach
 * r = a2 cos q2 + a3 cos(q2 + q3) (front: r >= 0); the elbow branch is the sign of sin q3
 * (paper eq 6: "-" sign = elbow up, i.e. sin q3 <= 0; "+" sign = elbow down, sin q3 > 0).
 * The branch index is shoulder * 2 + elbow.
 */
typedef enum rrr_shoulder {
    RRR_SHOULDER_FRONT = 0,      ///< r >= 0: the tip in front of the shoulder
    RRR_SHOULDER_BACK = 1        ///< r < 0: the arm reaching back over the shoulder
} rrr_shoulder;
/** @brief The elbow branch (see rrr_shoulder): up is sin q3 <= 0, down sin q3 > 0. */
typedef enum rrr_elbow {
    RRR_ELBOW_UP = 0,            ///< sin q3 <= 0 (the "-" sign of eq 6)
    RRR_ELBOW_DOWN = 1           ///< sin q3 > 0 (the "+" sign of eq 6)
} rrr_elbow;

/** @brief Every IK solution of one target. */
typedef struct rrr_ik_set {
    int n;                       ///< number of distinct solutions, 0..4
    double q[4][3];              ///< solutions, rad, each joint in (-pi, pi]
    int branch[4];               ///< branch index shoulder * 2 + elbow of each solution
} rrr_ik_set;

/** Largest |q_prev| that rrr_ik_nearest unwraps to (the spacing of doubles there is 1.2e-10 rad). */
#define RRR_Q_UNWRAP_MAX 1e6

/** Singularity flags (bits of rrr_singularity.flags). */
#define RRR_SING_ELBOW_STRETCHED 1u   ///< q3 = 0 (mod 2 pi): elbow straight, tip on the outer workspace boundary
#define RRR_SING_ELBOW_FOLDED    2u   ///< q3 = pi (mod 2 pi): elbow folded back, tip on the inner boundary
#define RRR_SING_SHOULDER        4u   ///< r = 0: tip on the shoulder-singular cylinder x^2 + y^2 = (d2 + d3)^2
#define RRR_SING_OUT_OF_REACH    8u   ///< target outside the workspace (rrr_workspace_margin only)

/** @brief Distance of a configuration from the singular set. */
typedef struct rrr_singularity {
    unsigned flags;              ///< RRR_SING_* bits: which singular sets are within the tolerance
    double elbow_margin;         ///< |sin q3| in [0, 1]: 0 at a stretched or folded elbow
    double shoulder_margin;      ///< |r| = |a2 cos q2 + a3 cos(q2 + q3)| in m: 0 on the shoulder cylinder
    double det_jacobian;         ///< det J(q) = -a2 a3 sin q3 r, m^3
} rrr_singularity;

/**
 * @brief Forward kinematics, eqs 3-5.
 * @param[in]  m model
 * @param[in]  q joint angles, rad
 * @param[out] x tip position in frame 0, m
 * @param[out] R orientation O(q) of the end frame (eq 4), row-major; may be NULL
 * @return RRR_OK or RRR_BAD_INPUT
 */
RRR_API rrr_status rrr_fk(const rrr_model *m, const double q[3], double x[3], double R[3][3]);

/** Number of frames of rrr_fk_frames: DH frames 0..3 (frame 3 is the tool, the pen tip). */
#define RRR_NFRAMES (RRR_NJ + 1)

/**
 * @brief Every DH frame of the chain and the tool pose, in frame 0 (for a TF tree or a viewer).
 *
 * T[k] is the homogeneous transform of DH frame k into frame 0 (row-major 4 x 4, last row
 * 0 0 0 1): T[0] = I (the base), T[k] = T[k-1] Rz(q_k) Tz(d_k) Tx(a_k) Rx(alpha_k) with the DH
 * table of docs/conventions.md, and T[3] the tool, whose rotation and position are those of
 * rrr_fk bit for bit. The URDF link k (rrr urdf) is DH frame k-1 turned by q_k about its z.
 * @param[out] T frames 0..3
 * @return RRR_OK or RRR_BAD_INPUT (T untouched)
 */
RRR_API rrr_status rrr_fk_frames(const rrr_model *m, const double q[3],
                                 double T[RRR_NFRAMES][4][4]);

/**
 * @brief Position Jacobian J = dx/dq of the tip (3 x 3, row-major, J[i][j] = d x_i / d q_j).
 * @return RRR_OK or RRR_BAD_INPUT
 */
RRR_API rrr_status rrr_jacobian(const rrr_model *m, const double q[3], double J[3][3]);

/**
 * @brief Tip velocity and acceleration from joint motion: xd = J qd, xdd = J qdd + Jd qd.
 * @param[out] xd tip velocity, m/s (may be NULL)
 * @param[out] xdd tip acceleration, m/s^2 (may be NULL)
 */
RRR_API rrr_status rrr_tip_motion(const rrr_model *m, const double q[3], const double qd[3],
                          const double qdd[3], double xd[3], double xdd[3]);

/**
 * @brief Joint velocity and acceleration from tip motion: qd = J^-1 xd, qdd = J^-1 (xdd - Jd qd).
 * @return RRR_OK, RRR_BAD_INPUT, or RRR_SINGULAR when |det J| <= 1e-12 (a2 + a3)^3
 */
RRR_API rrr_status rrr_joint_motion(const rrr_model *m, const double q[3], const double xd[3],
                            const double xdd[3], double qd[3], double qdd[3]);

/**
 * @brief Inverse kinematics on one posture branch (eq 6 in a form valid in the whole workspace).
 * @param[in]  shoulder RRR_SHOULDER_FRONT or RRR_SHOULDER_BACK
 * @param[in]  elbow    RRR_ELBOW_UP or RRR_ELBOW_DOWN
 * @param[out] q joint angles in (-pi, pi]
 * @return RRR_OK, RRR_BAD_INPUT, RRR_UNREACHABLE (x^2 + y^2 < (d2+d3)^2 or the wrist distance is
 *         outside [|a2 - a3|, a2 + a3])
 */
RRR_API rrr_status rrr_ik_branch(const rrr_model *m, const double x[3], rrr_shoulder shoulder,
                         rrr_elbow elbow, double q[3]);

/**
 * @brief Every inverse kinematics solution of a target (up to four; branches that coincide at a
 *        singular target are returned once).
 * @return RRR_OK (sol->n >= 1), RRR_BAD_INPUT or RRR_UNREACHABLE (sol untouched)
 */
RRR_API rrr_status rrr_ik(const rrr_model *m, const double x[3], rrr_ik_set *sol);

/**
 * @brief The IK solution nearest to a given configuration, unwrapped by multiples of 2 pi per
 *        joint (the joints turn without limit), so that a trajectory stays continuous.
 * @param[in]  q_prev configuration to stay near, |q_prev_i| <= RRR_Q_UNWRAP_MAX (about 160,000
 *                    turns: beyond it a double cannot hold the unwrapped angle to 1e-9 rad)
 * @param[out] q      solution with |q_i - q_prev_i| <= pi on every joint
 * @param[out] branch if not NULL, branch index of the chosen solution
 * @return RRR_OK, RRR_BAD_INPUT (also for |q_prev_i| > RRR_Q_UNWRAP_MAX) or RRR_UNREACHABLE
 */
RRR_API rrr_status rrr_ik_nearest(const rrr_model *m, const double x[3], const double q_prev[3],
                          double q[3], int *branch);

/**
 * @brief Classify a configuration against the singular sets.
 * @param[in] tol flags a set when its margin is <= tol (elbow: |sin q3| <= tol; shoulder: |r| <= tol (a2 + a3))
 * @return RRR_OK or RRR_BAD_INPUT
 */
RRR_API rrr_status rrr_singularity_classify(const rrr_model *m, const double q[3], double tol,
                                    rrr_singularity *s);

/**
 * @brief Signed distance of a target from the workspace boundary, m: > 0 inside (reachable),
 *        < 0 outside. The boundary consists of the outer sphere (a2 + a3), the inner sphere
 *        |a2 - a3| (about the shoulder) and the shoulder cylinder of radius |d2 + d3|.
 * @param[out] margin distance, m
 * @param[out] flags  if not NULL, RRR_SING_OUT_OF_REACH when margin < 0, else 0
 * @return RRR_OK, RRR_BAD_INPUT, or RRR_NUMERIC (a finite target so far out that the margin
 *         is not a finite number)
 */
RRR_API rrr_status rrr_workspace_margin(const rrr_model *m, const double x[3], double *margin,
                                unsigned *flags);

#ifdef __cplusplus
}
#endif
#endif /* RRR_KINEMATICS_H */
