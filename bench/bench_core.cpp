// Benchmark driver: the closed-form core librrr (C) against Pinocchio (C++) on the SAME robot
// (the default robot of rrr_model_default / rrr_inertial_default) and the SAME pre-generated
// random states. Prints one JSON object per line (kind = meta | group | check | info); the
// table is assembled by bench/run_bench.py.
//
// Timing, interleaved: the operations compared with each other form a group (ours and the
// reference, e.g. rrr_inverse_dynamics and rnea). Each of `--repeats` repeats runs one block of
// every operation of the group back to back (in order on even repeats, in reverse order on odd
// ones); a block is `--calls` calls (rounded up to whole passes over the `--states`
// pre-generated states; the numeric IK 1/20 of that) cycling over the states from the first,
// so every operation sees the same states. Per repeat: ns/call of each block and the ratio
// reference / ours of the same repeat; printed with min / median / max over the repeats. A
// throughput loop: consecutive calls are independent. One output of every call is summed into
// a sink written to a volatile global, so no call can be optimised away (the calls cross into
// librrr.a and libpinocchio_default.so anyway: no LTO).
//
// Blocks are timed by the CPU time of the thread (CLOCK_THREAD_CPUTIME_ID): on a loaded machine
// the time this process waits for a core is not counted; --clock wall times them by the wall
// clock instead.
//
// Usage: bench_core [--states N (power of 2)] [--calls N] [--repeats N] [--seed N] [--ik-tol E]
//                   [--clock cpu|wall]
//
// Compile time: every Pinocchio call goes to the library's explicit instantiation for
// pinocchio::Model / Data (libpinocchio_default, PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION), so
// this file compiles none of the algorithms again (each would instantiate its visitors for every
// joint type; g++ 12 front end: computeFrameJacobian 8 CPU-s, computeJointTorqueRegressor 13,
// crba and aba 60 together: the build took 100 CPU-s, now 18). crba and aba take
// Eigen::Ref<const VectorXd>, the argument type the library instantiated them for;
// computeJointTorqueRegressor and computeFrameJacobian are declared `inline` by Pinocchio, which
// makes g++ compile their bodies whenever the definition is visible (extern template or not), so
// their headers are not included and the instantiations the library exports are declared below.
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <limits>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "rrr/rrr.h"

#ifdef BENCH_INTERNALS
// private header of librrr: rrr_trig_of and the generated kernels, without the input checks
#include <math.h>
#include <stddef.h>
extern "C" {
#include "rrr_dynamics_gen.h"
}
#endif

namespace pinocchio {
// pinocchio/algorithm/regressor.hpp and frames.hpp (Pinocchio 3.x/4.x), without the bodies: the
// calls below link to libpinocchio_default's instantiations for Model, Data, VectorXd, Matrix6x
// (exported symbols; a Pinocchio whose signature differs fails to link, it cannot run silently).
template <typename Scalar, int Options, template <typename, int> class JointCollectionTpl,
          typename ConfigVectorType, typename TangentVectorType1, typename TangentVectorType2>
typename DataTpl<Scalar, Options, JointCollectionTpl>::MatrixXs &computeJointTorqueRegressor(
    const ModelTpl<Scalar, Options, JointCollectionTpl> &model,
    DataTpl<Scalar, Options, JointCollectionTpl> &data,
    const Eigen::MatrixBase<ConfigVectorType> &q, const Eigen::MatrixBase<TangentVectorType1> &v,
    const Eigen::MatrixBase<TangentVectorType2> &a);

template <typename Scalar, int Options, template <typename, int> class JointCollectionTpl,
          typename ConfigVectorType, typename Matrix6xLike>
void computeFrameJacobian(const ModelTpl<Scalar, Options, JointCollectionTpl> &model,
                          DataTpl<Scalar, Options, JointCollectionTpl> &data,
                          const Eigen::MatrixBase<ConfigVectorType> &q, const FrameIndex frame_id,
                          const ReferenceFrame reference_frame,
                          const Eigen::MatrixBase<Matrix6xLike> &J);
}  // namespace pinocchio

namespace {

// crba's and aba's argument type in libpinocchio_default
using CRef = Eigen::Ref<const Eigen::VectorXd>;

constexpr double kPi = 3.14159265358979323846;

volatile double g_sink = 0.0;  // results of every timed loop end here

struct Options {
    std::size_t states = 1024;  // power of two (index = i & (states - 1))
    long calls = 20480;         // calls per block (rounded up to whole passes over the states)
    int repeats = 31;           // blocks of each operation (interleaved)
    unsigned long seed = 20240601;
    double ik_tol = 1e-12;      // numeric IK stops when 1/2 |e|^2 < ik_tol (as RTB's tol)
    bool wall_clock = false;    // blocks timed by the thread's CPU time (or the wall clock)
};

using V3 = std::array<double, 3>;

struct States {
    std::vector<V3> q, qd, qdd, tau, x, q_ik;          // plain arrays for librrr
    std::vector<Eigen::VectorXd> eq, eqd, eqdd, etau;  // the same numbers for Pinocchio
};

// ------------------------------------------------------------------------------------------
// Output
// ------------------------------------------------------------------------------------------
struct Op {
    const char *id;
    long calls;  // calls per block
};

struct Ratio {
    std::size_t num, den;  // ns[num] / ns[den] of the same repeat
};

struct Stats {
    double min, median, max;
};

Stats stats(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    const std::size_t h = v.size() / 2;
    const double median = v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
    return {v.front(), median, v.back()};
}

void print_series(const std::vector<double> &v)
{
    const Stats st = stats(v);
    std::printf("\"min\": %.6g, \"median\": %.6g, \"max\": %.6g, \"values\": [", st.min,
                st.median, st.max);
    for (std::size_t i = 0; i < v.size(); ++i) {
        std::printf("%s%.6g", i ? ", " : "", v[i]);
    }
    std::printf("]");
}

// One JSON line per group: every operation's ns/call per repeat (in repeat order) and the
// per-repeat ratios, each with its min / median / max.
void print_group(const char *group, const std::vector<Op> &ops,
                 const std::vector<std::vector<double>> &ns, const std::vector<Ratio> &ratios)
{
    std::printf("{\"kind\": \"group\", \"id\": \"%s\", \"repeats\": %zu, \"ops\": [", group,
                ns[0].size());
    for (std::size_t j = 0; j < ops.size(); ++j) {
        std::printf("%s{\"id\": \"%s\", \"calls\": %ld, ", j ? ", " : "", ops[j].id,
                    ops[j].calls);
        print_series(ns[j]);
        std::printf("}");
    }
    std::printf("], \"ratios\": [");
    for (std::size_t r = 0; r < ratios.size(); ++r) {
        std::vector<double> v;
        for (std::size_t i = 0; i < ns[0].size(); ++i) {
            v.push_back(ns[ratios[r].num][i] / ns[ratios[r].den][i]);
        }
        std::printf("%s{\"id\": \"%s/%s\", ", r ? ", " : "", ops[ratios[r].num].id,
                    ops[ratios[r].den].id);
        print_series(v);
        std::printf("}");
    }
    std::printf("]}\n");
    std::fflush(stdout);
}

void print_check(const std::string &id, double max_abs_diff, double scale)
{
    std::printf("{\"kind\": \"check\", \"id\": \"%s\", \"max_abs_diff\": %.3e, \"scale\": %.3e}\n",
                id.c_str(), max_abs_diff, scale);
}

// ------------------------------------------------------------------------------------------
// Interleaved timing
// ------------------------------------------------------------------------------------------
// The clock of the blocks: the CPU time of this thread (default: the time other processes run
// while this one waits for a core is left out) or the wall clock (steady_clock).
bool g_wall_clock = false;

double now_ns()
{
    if (g_wall_clock) {
        return std::chrono::duration<double, std::nano>(
                   std::chrono::steady_clock::now().time_since_epoch())
            .count();
    }
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return 1e9 * static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec);
}

// One block: `calls` calls of f(k), k cycling over the states from state 0; ns per call.
template <class F>
double block(F &f, long calls, std::size_t mask, double &sink)
{
    const double t0 = now_ns();
    for (long i = 0; i < calls; ++i) {
        sink += f(static_cast<std::size_t>(i) & mask);
    }
    return (now_ns() - t0) / static_cast<double>(calls);
}

// The block of operation `which` (the loop of each lambda is its own instantiation, so the
// calls are inlined into it as in a plain loop).
template <class Tuple, std::size_t... I>
double block_at(std::size_t which, Tuple &fs, const std::vector<Op> &ops, std::size_t mask,
                double &sink, std::index_sequence<I...>)
{
    double ns = 0.0;
    ((which == I ? static_cast<void>(ns = block(std::get<I>(fs), ops[I].calls, mask, sink))
                 : static_cast<void>(0)),
     ...);
    return ns;
}

// Times the operations of a group interleaved: every repeat runs one block of each, in order
// on even repeats and in reverse order on odd ones, all on the same states, so a change of
// machine load hits every operation of the group alike. One warm-up pass over the states each.
template <class... F>
void time_group(const char *group, const Options &o, const std::vector<Op> &ops,
                const std::vector<Ratio> &ratios, F... f)
{
    constexpr std::size_t n = sizeof...(F);
    if (ops.size() != n) {
        std::fprintf(stderr, "bench_core: group %s: %zu names for %zu operations\n", group,
                     ops.size(), n);
        std::exit(2);
    }
    auto fs = std::make_tuple(f...);
    const auto seq = std::index_sequence_for<F...>{};
    const std::size_t mask = o.states - 1;
    double sink = 0.0;
    std::vector<Op> warm = ops;
    for (Op &w : warm) {
        w.calls = static_cast<long>(o.states);
    }
    for (std::size_t j = 0; j < n; ++j) {
        block_at(j, fs, warm, mask, sink, seq);
    }
    std::vector<std::vector<double>> ns(n);
    for (int r = 0; r < o.repeats; ++r) {
        for (std::size_t j = 0; j < n; ++j) {
            const std::size_t which = r % 2 == 0 ? j : n - 1 - j;
            ns[which].push_back(block_at(which, fs, ops, mask, sink, seq));
        }
    }
    g_sink = g_sink + sink;
    print_group(group, ops, ns, ratios);
}

void require_ok(rrr_status st, const char *what)
{
    if (st != RRR_OK) {
        std::fprintf(stderr, "bench_core: %s failed: %s\n", what, rrr_status_str(st));
        std::exit(2);
    }
}

// ------------------------------------------------------------------------------------------
// The same robot in Pinocchio
// ------------------------------------------------------------------------------------------
// Tz(d) Tx(a) Rx(alpha): the fixed part of the standard DH transform A_i = Rz(q_i) Tz Tx Rx.
pinocchio::SE3 dh_fixed(double d, double a, double alpha)
{
    Eigen::Matrix3d rx;
    rx << 1.0, 0.0, 0.0, 0.0, std::cos(alpha), -std::sin(alpha), 0.0, std::sin(alpha),
        std::cos(alpha);
    return pinocchio::SE3(rx, Eigen::Vector3d(a, 0.0, d));
}

// Joint i rotates frame i-1 about z (JointModelRZ); joint i+1 sits at Tz(d_i) Tx(a_i) Rx(alpha_i)
// from joint i. Link i is given in DH frame i, which is that fixed transform away from joint i:
// com = p + R r_c, I = R I_c R^T. armature = J_m, so rnea/crba/aba include the rotor inertia
// exactly as tau = R p does. A frame "tip" at the origin of DH frame 3 serves FK and IK.
pinocchio::Model pinocchio_model(const rrr_model &m, const rrr_inertial &in,
                                 pinocchio::FrameIndex *tip, pinocchio::SE3 *tip_placement)
{
    pinocchio::Model model;
    model.gravity.linear(Eigen::Vector3d(0.0, 0.0, -m.g));
    const double alpha[3] = {kPi / 2.0, 0.0, 0.0};
    const double a[3] = {0.0, m.a2, m.a3};
    const double d[3] = {m.d1, m.d2, m.d3};
    pinocchio::JointIndex parent = 0;
    pinocchio::SE3 placement = pinocchio::SE3::Identity();
    for (int i = 0; i < 3; ++i) {
        const pinocchio::JointIndex joint = model.addJoint(
            parent, pinocchio::JointModelRZ(), placement, "joint" + std::to_string(i + 1));
        const pinocchio::SE3 fixed = dh_fixed(d[i], a[i], alpha[i]);
        const rrr_link_inertia &l = in.link[i];
        Eigen::Matrix3d ic;
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) {
                ic(r, c) = l.inertia_com[r][c];
            }
        }
        const Eigen::Vector3d com =
            fixed.translation() + fixed.rotation() * Eigen::Vector3d(l.com[0], l.com[1], l.com[2]);
        const Eigen::Matrix3d inertia = fixed.rotation() * ic * fixed.rotation().transpose();
        model.appendBodyToJoint(joint, pinocchio::Inertia(l.mass, com, inertia),
                                pinocchio::SE3::Identity());
        parent = joint;
        placement = fixed;
    }
    model.armature = Eigen::Vector3d(in.rotor_inertia[0], in.rotor_inertia[1], in.rotor_inertia[2]);
    *tip = model.addFrame(pinocchio::Frame("tip", parent, placement, pinocchio::OP_FRAME));
    *tip_placement = placement;
    return model;
}

// Numeric position IK on Pinocchio kinematics, written here as a compiled reference for RTB's
// ets.ik_LM: the same algorithm (Levenberg-Marquardt with Chan's damping lambda = k E, k = 1,
// position-only mask, E = 1/2 |e|^2 < tol, at most 30 iterations per search and 100 searches,
// the first from q0 = (0.1, 0.2, 1.0), the others from random q in [-pi, pi]^3).
// Returns the number of iterations, or -1 when every search failed.
struct NumericIk {
    const pinocchio::Model &model;
    pinocchio::Data &data;
    pinocchio::FrameIndex tip;
    double tol;
    int ilimit = 30;
    int slimit = 100;
    Eigen::Matrix<double, 6, Eigen::Dynamic> J;
    std::mt19937_64 rng{12345};
    std::uniform_real_distribution<double> ang{-kPi, kPi};

    NumericIk(const pinocchio::Model &m, pinocchio::Data &d, pinocchio::FrameIndex t, double e)
        : model(m), data(d), tip(t), tol(e), J(6, m.nv)
    {
        J.setZero();
    }

    // the random restarts start again from the same seed
    void reset()
    {
        rng.seed(12345);
        ang.reset();
    }

    int solve(const V3 &x, Eigen::VectorXd &q)
    {
        const Eigen::Vector3d target(x[0], x[1], x[2]);
        int iterations = 0;
        for (int search = 0; search < slimit; ++search) {
            if (search == 0) {
                q = Eigen::Vector3d(0.1, 0.2, 1.0);
            } else {
                q = Eigen::Vector3d(ang(rng), ang(rng), ang(rng));
            }
            for (int it = 0; it < ilimit; ++it) {
                pinocchio::computeFrameJacobian(model, data, q, tip,
                                                pinocchio::LOCAL_WORLD_ALIGNED, J);
                const Eigen::Vector3d e = target - data.oMf[tip].translation();
                const double energy = 0.5 * e.squaredNorm();
                if (energy < tol) {
                    return iterations;
                }
                const Eigen::Matrix3d jp = J.topRows<3>();
                Eigen::Matrix3d a = jp.transpose() * jp;
                a.diagonal().array() += energy;  // Chan: W_n = k E 1, k = 1
                q += a.ldlt().solve(jp.transpose() * e);
                ++iterations;
            }
        }
        return -1;
    }
};

// ------------------------------------------------------------------------------------------
// States
// ------------------------------------------------------------------------------------------
States make_states(const rrr_model &m, const Options &o)
{
    std::mt19937_64 rng(o.seed);
    std::uniform_real_distribution<double> ang(-kPi, kPi), vel(-3.0, 3.0), acc(-10.0, 10.0);
    std::uniform_real_distribution<double> q2(-kPi / 2.0, kPi / 2.0), q3(0.2, 2.5);
    States s;
    for (std::size_t k = 0; k < o.states; ++k) {
        V3 q = {ang(rng), ang(rng), ang(rng)};
        V3 qd = {vel(rng), vel(rng), vel(rng)};
        V3 qdd = {acc(rng), acc(rng), acc(rng)};
        V3 tau;
        require_ok(rrr_inverse_dynamics(&m, q.data(), qd.data(), qdd.data(), tau.data()), "tau");
        // IK targets: the same distribution as run_bench.py uses for RTB (q3 away from 0 and pi)
        V3 qi = {ang(rng), q2(rng), q3(rng)};
        V3 x;
        require_ok(rrr_fk(&m, qi.data(), x.data(), nullptr), "fk");
        s.q.push_back(q);
        s.qd.push_back(qd);
        s.qdd.push_back(qdd);
        s.tau.push_back(tau);
        s.q_ik.push_back(qi);
        s.x.push_back(x);
        s.eq.push_back(Eigen::Vector3d(q[0], q[1], q[2]));
        s.eqd.push_back(Eigen::Vector3d(qd[0], qd[1], qd[2]));
        s.eqdd.push_back(Eigen::Vector3d(qdd[0], qdd[1], qdd[2]));
        s.etau.push_back(Eigen::Vector3d(tau[0], tau[1], tau[2]));
    }
    return s;
}

double wrap(double a)
{
    return std::remainder(a, 2.0 * kPi);
}

Options parse(int argc, char **argv)
{
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (i + 1 >= argc) {
            std::fprintf(stderr, "bench_core: %s needs a value\n", a.c_str());
            std::exit(1);
        }
        const char *v = argv[++i];
        if (a == "--states") {
            o.states = std::strtoul(v, nullptr, 10);
        } else if (a == "--calls") {
            o.calls = std::strtol(v, nullptr, 10);
        } else if (a == "--repeats") {
            o.repeats = std::atoi(v);
        } else if (a == "--seed") {
            o.seed = std::strtoul(v, nullptr, 10);
        } else if (a == "--ik-tol") {
            o.ik_tol = std::strtod(v, nullptr);
        } else if (a == "--clock") {
            if (std::strcmp(v, "cpu") != 0 && std::strcmp(v, "wall") != 0) {
                std::fprintf(stderr, "bench_core: --clock is cpu or wall\n");
                std::exit(1);
            }
            o.wall_clock = std::strcmp(v, "wall") == 0;
        } else {
            std::fprintf(stderr, "bench_core: unknown option %s\n", a.c_str());
            std::exit(1);
        }
    }
    if (o.states == 0 || (o.states & (o.states - 1)) != 0 || o.calls <= 0 || o.repeats <= 0) {
        std::fprintf(stderr, "bench_core: --states must be a power of 2, --calls/--repeats > 0\n");
        std::exit(1);
    }
    return o;
}

}  // namespace

int main(int argc, char **argv)
{
    const Options o = parse(argc, argv);
    g_wall_clock = o.wall_clock;
    rrr_model m;
    rrr_inertial in;
    require_ok(rrr_model_default(&m), "rrr_model_default");
    require_ok(rrr_inertial_default(&in), "rrr_inertial_default");
    pinocchio::FrameIndex tip = 0;
    pinocchio::SE3 tip_fixed;
    const pinocchio::Model model = pinocchio_model(m, in, &tip, &tip_fixed);
    pinocchio::Data data(model);
    const States s = make_states(m, o);
    const std::size_t n = o.states;

    std::printf("{\"kind\": \"meta\", \"cxx\": \"%s\", \"c\": \"%s\", \"pinocchio\": \"%s\", "
                "\"eigen\": \"%d.%d.%d\", \"rrr\": \"%s\", \"states\": %zu, \"calls\": %ld, "
                "\"repeats\": %d, \"seed\": %lu, \"ik_tol\": %.3g, \"clock\": \"%s\"}\n",
                BENCH_CXX_FLAGS, BENCH_C_FLAGS, BENCH_PINOCCHIO_VERSION, EIGEN_WORLD_VERSION,
                EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION, RRR_VERSION_STRING, n, o.calls,
                o.repeats, o.seed, o.ik_tol, o.wall_clock ? "wall" : "cpu");

    // ---------------------------------------------------------------- agreement checks
    {
        double fk_pos = 0.0, fk_rot = 0.0, tau = 0.0, reg = 0.0, mass = 0.0, cor = 0.0, grav = 0.0,
               nle = 0.0, fd = 0.0, sc_tau = 0.0, sc_mass = 0.0, sc_grav = 0.0, sc_nle = 0.0,
               sc_fd = 0.0;
        const double zero[3] = {0.0, 0.0, 0.0};
        for (std::size_t k = 0; k < n; ++k) {
            double x[3], rot[3][3], t[3], y[3][RRR_NP], dm[3][3], c[3], h[3], b[3], a[3];
            require_ok(rrr_fk(&m, s.q[k].data(), x, rot), "fk");
            require_ok(rrr_inverse_dynamics(&m, s.q[k].data(), s.qd[k].data(), s.qdd[k].data(), t),
                       "tau");
            require_ok(rrr_regressor(&m, s.q[k].data(), s.qd[k].data(), s.qdd[k].data(), y),
                       "regressor");
            require_ok(rrr_mass_matrix(&m, s.q[k].data(), dm), "D");
            require_ok(rrr_coriolis(&m, s.q[k].data(), s.qd[k].data(), c), "c");
            require_ok(rrr_gravity(&m, s.q[k].data(), h), "h");
            require_ok(rrr_inverse_dynamics(&m, s.q[k].data(), s.qd[k].data(), zero, b), "c + h");
            require_ok(rrr_forward_dynamics(&m, s.q[k].data(), s.qd[k].data(), s.tau[k].data(), a),
                       "fd");

            pinocchio::forwardKinematics(model, data, s.eq[k]);
            const pinocchio::SE3 pose = data.oMi[3] * tip_fixed;
            const Eigen::VectorXd &rt = pinocchio::rnea(model, data, s.eq[k], s.eqd[k], s.eqdd[k]);
            const Eigen::Vector3d rtau = rt;
            pinocchio::crba(model, data, CRef(s.eq[k]));
            const Eigen::Matrix3d upper = data.M;  // crba fills the upper triangle
            Eigen::Matrix3d pm = upper.triangularView<Eigen::Upper>();
            pm.triangularView<Eigen::StrictlyLower>() = upper.transpose();
            const Eigen::Vector3d pg = pinocchio::computeGeneralizedGravity(model, data, s.eq[k]);
            const Eigen::Vector3d pn = pinocchio::nonLinearEffects(model, data, s.eq[k], s.eqd[k]);
            const Eigen::Vector3d pa =
                pinocchio::aba(model, data, CRef(s.eq[k]), CRef(s.eqd[k]), CRef(s.etau[k]));

            for (int i = 0; i < 3; ++i) {
                fk_pos = std::max(fk_pos, std::abs(x[i] - pose.translation()[i]));
                double rp = 0.0;
                for (int j = 0; j < RRR_NP; ++j) {
                    rp += y[i][j] * m.p[j];
                }
                reg = std::max(reg, std::abs(rp - rtau[i]));
                tau = std::max(tau, std::abs(t[i] - rtau[i]));
                cor = std::max(cor, std::abs(c[i] - (pn[i] - pg[i])));
                grav = std::max(grav, std::abs(h[i] - pg[i]));
                nle = std::max(nle, std::abs(b[i] - pn[i]));
                fd = std::max(fd, std::abs(a[i] - pa[i]));
                sc_tau = std::max(sc_tau, std::abs(rtau[i]));
                sc_grav = std::max(sc_grav, std::abs(pg[i]));
                sc_nle = std::max(sc_nle, std::abs(pn[i]));
                sc_fd = std::max(sc_fd, std::abs(pa[i]));
                for (int j = 0; j < 3; ++j) {
                    fk_rot = std::max(fk_rot, std::abs(rot[i][j] - pose.rotation()(i, j)));
                    mass = std::max(mass, std::abs(dm[i][j] - pm(i, j)));
                    sc_mass = std::max(sc_mass, std::abs(pm(i, j)));
                }
            }
        }
        print_check("fk_position", fk_pos, 1.0);
        print_check("fk_rotation", fk_rot, 1.0);
        print_check("tau", tau, sc_tau);
        print_check("regressor", reg, sc_tau);
        print_check("mass", mass, sc_mass);
        print_check("coriolis", cor, sc_nle);
        print_check("gravity", grav, sc_grav);
        print_check("nle", nle, sc_nle);
        print_check("fd", fd, sc_fd);

        // IK: every branch maps back onto the target; the generating q is among the branches
        double ik_fk = 0.0, ik_q = 0.0;
        int solutions = 0;
        for (std::size_t k = 0; k < n; ++k) {
            rrr_ik_set set;
            require_ok(rrr_ik(&m, s.x[k].data(), &set), "ik");
            solutions += set.n;
            double best = std::numeric_limits<double>::infinity();
            for (int b = 0; b < set.n; ++b) {
                double x[3];
                require_ok(rrr_fk(&m, set.q[b], x, nullptr), "fk");
                double dq = 0.0;
                for (int i = 0; i < 3; ++i) {
                    ik_fk = std::max(ik_fk, std::abs(x[i] - s.x[k][i]));
                    dq = std::max(dq, std::abs(wrap(set.q[b][i] - s.q_ik[k][i])));
                }
                best = std::min(best, dq);
            }
            ik_q = std::max(ik_q, best);
        }
        print_check("ik_fk", ik_fk, 1.0);
        print_check("ik_q", ik_q, kPi);
        std::printf("{\"kind\": \"info\", \"id\": \"ik.ours\", \"targets\": %zu, "
                    "\"mean_solutions\": %.3f}\n",
                    n, static_cast<double>(solutions) / static_cast<double>(n));

        // the numeric reference IK: success rate, iterations, position error
        NumericIk nik(model, data, tip, o.ik_tol);
        Eigen::VectorXd q(3);
        int ok = 0;
        long iters = 0;
        double err = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
            const int it = nik.solve(s.x[k], q);
            if (it >= 0) {
                ++ok;
                iters += it;
                double x[3];
                const double qa[3] = {q[0], q[1], q[2]};
                require_ok(rrr_fk(&m, qa, x, nullptr), "fk");
                for (int i = 0; i < 3; ++i) {
                    err = std::max(err, std::abs(x[i] - s.x[k][i]));
                }
            }
        }
        std::printf("{\"kind\": \"info\", \"id\": \"ik.pin_lm\", \"targets\": %zu, \"success\": %d, "
                    "\"mean_iterations\": %.3f, \"max_position_error\": %.3e}\n",
                    n, ok, ok ? static_cast<double>(iters) / ok : 0.0, err);
        std::fflush(stdout);
    }

    // ---------------------------------------------------------------- timings
    // Every group runs its operations in alternating blocks on the same states; `calls` is
    // rounded up to whole passes over the states so every block sees each state equally often.
    const double zero[3] = {0.0, 0.0, 0.0};
    const long passes = (o.calls + static_cast<long>(n) - 1) / static_cast<long>(n);
    const long calls = passes * static_cast<long>(n);
    const long lm_calls = std::max<long>(1, passes / 20) * static_cast<long>(n);  // ~20x slower

    // libm floor of the closed forms: sin/cos of q2, q3 as in rrr_trig_of (gcc fuses each pair
    // into one sincos call), and one atan2 (rrr_ik and rrr_ik_branch make 5 each); the empty loop.
    auto empty = [&](std::size_t k) { return s.q[k][0]; };
    auto trig = [&](std::size_t k) {
        const double s2 = std::sin(s.q[k][1]), c2 = std::cos(s.q[k][1]);
        const double s3 = std::sin(s.q[k][2]), c3 = std::cos(s.q[k][2]);
        return (s2 * c3 + c2 * s3) + (c2 * c3 - s2 * s3);
    };
    auto atan2_1 = [&](std::size_t k) { return std::atan2(s.x[k][1], s.x[k][0]); };
    auto tau_ours = [&](std::size_t k) {
        double t[3];
        rrr_inverse_dynamics(&m, s.q[k].data(), s.qd[k].data(), s.qdd[k].data(), t);
        return t[0];
    };
#ifdef BENCH_INTERNALS
    // what rrr_inverse_dynamics costs without its argument checks
    auto kernel_tau = [&](std::size_t k) {
        const rrr_trig t = rrr_trig_of(s.q[k].data());
        double out[3];
        rrr_gen_inverse_dynamics(&m, &t, s.qd[k].data(), s.qdd[k].data(), out);
        return out[0];
    };
    time_group("diagnostics", o,
               {{"tau.ours", calls}, {"kernel.tau", calls}, {"floor.trig", calls},
                {"floor.atan2", calls}, {"loop.empty", calls}},
               {{1, 0}}, tau_ours, kernel_tau, trig, atan2_1, empty);
#else
    time_group("diagnostics", o,
               {{"tau.ours", calls}, {"floor.trig", calls}, {"floor.atan2", calls},
                {"loop.empty", calls}},
               {}, tau_ours, trig, atan2_1, empty);
#endif

    time_group(
        "fk", o, {{"fk.ours", calls}, {"fk.pin", calls}}, {{1, 0}},
        [&](std::size_t k) {
            double x[3], rot[3][3];
            rrr_fk(&m, s.q[k].data(), x, rot);
            return x[0] + rot[0][0];
        },
        [&](std::size_t k) {
            pinocchio::forwardKinematics(model, data, s.eq[k]);
            const pinocchio::SE3 pose = data.oMi[3] * tip_fixed;
            return pose.translation()[0] + pose.rotation()(0, 0);
        });

    {
        NumericIk nik(model, data, tip, o.ik_tol);
        Eigen::VectorXd q(3);
        time_group(
            "ik", o, {{"ik.ours", calls}, {"ik_branch.ours", calls}, {"ik.pin_lm", lm_calls}},
            {{2, 0}, {2, 1}},
            [&](std::size_t k) {
                rrr_ik_set set;
                rrr_ik(&m, s.x[k].data(), &set);
                return set.q[0][0] + set.n;
            },
            [&](std::size_t k) {
                double qb[3];
                rrr_ik_branch(&m, s.x[k].data(), RRR_SHOULDER_FRONT, RRR_ELBOW_UP, qb);
                return qb[0];
            },
            [&](std::size_t k) {
                if (k == 0) {
                    nik.reset();  // every pass over the targets draws the same restarts
                }
                const int it = nik.solve(s.x[k], q);
                return q[0] + it;
            });
    }

    time_group("tau", o, {{"tau.ours", calls}, {"tau.pin", calls}}, {{1, 0}}, tau_ours,
               [&](std::size_t k) {
                   return pinocchio::rnea(model, data, s.eq[k], s.eqd[k], s.eqdd[k])[0];
               });

    time_group(
        "regressor", o, {{"regressor.ours", calls}, {"regressor.pin", calls}}, {{1, 0}},
        [&](std::size_t k) {
            double y[3][RRR_NP];
            rrr_regressor(&m, s.q[k].data(), s.qd[k].data(), s.qdd[k].data(), y);
            return y[0][0];
        },
        [&](std::size_t k) {
            return pinocchio::computeJointTorqueRegressor(model, data, s.eq[k], s.eqd[k],
                                                          s.eqdd[k])(0, 0);
        });

    time_group(
        "mass", o, {{"mass.ours", calls}, {"mass.pin", calls}}, {{1, 0}},
        [&](std::size_t k) {
            double dm[3][3];
            rrr_mass_matrix(&m, s.q[k].data(), dm);
            return dm[0][0];
        },
        [&](std::size_t k) { return pinocchio::crba(model, data, CRef(s.eq[k]))(0, 0); });

    // Pinocchio has no c-only call: c and c + h are both compared with nonLinearEffects
    time_group(
        "nle", o, {{"coriolis.ours", calls}, {"nle.ours", calls}, {"nle.pin", calls}},
        {{2, 0}, {2, 1}},
        [&](std::size_t k) {
            double c[3];
            rrr_coriolis(&m, s.q[k].data(), s.qd[k].data(), c);
            return c[0];
        },
        [&](std::size_t k) {
            double b[3];
            rrr_inverse_dynamics(&m, s.q[k].data(), s.qd[k].data(), zero, b);
            return b[0];
        },
        [&](std::size_t k) {
            return pinocchio::nonLinearEffects(model, data, s.eq[k], s.eqd[k])[0];
        });

    time_group(
        "gravity", o, {{"gravity.ours", calls}, {"gravity.pin", calls}}, {{1, 0}},
        [&](std::size_t k) {
            double h[3];
            rrr_gravity(&m, s.q[k].data(), h);
            return h[1];
        },
        [&](std::size_t k) {
            return pinocchio::computeGeneralizedGravity(model, data, s.eq[k])[1];
        });

    time_group(
        "fd", o, {{"fd.ours", calls}, {"fd.pin", calls}}, {{1, 0}},
        [&](std::size_t k) {
            double a[3];
            rrr_forward_dynamics(&m, s.q[k].data(), s.qd[k].data(), s.tau[k].data(), a);
            return a[0];
        },
        [&](std::size_t k) {
            return pinocchio::aba(model, data, CRef(s.eq[k]), CRef(s.eqd[k]), CRef(s.etau[k]))[0];
        });

    std::printf("{\"kind\": \"info\", \"id\": \"sink\", \"value\": %.6e}\n", g_sink);
    return 0;
}
