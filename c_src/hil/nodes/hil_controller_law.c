/* The controller's law with its 0 V policy and its log row (hil_controller.h): no transport, so
 * that the firmware (c_src/firmware) compiles the same source as the node. */
#include <string.h>

#include "hil_controller.h"
#include "rrr_hil_logs.h"

int rrr_hil_ctrl_law(rrr_hil_ctrl *c, const rrr_hil_ctrl_opts *o, size_t k, int enable,
                     double u_V[3])
{
    rrr_ctc_output out;
    memset(&out, 0, sizeof out);
    const rrr_hil_ctc_fn ctc = c->ctc != NULL ? c->ctc : rrr_ctc;
    if (enable && ctc(&c->model, &o->gains, c->ref.q[k], c->ref.qd[k], c->ref.qdd[k], c->q, c->qd,
                      &out) != RRR_OK) {
        ++c->ctc_failed;
        enable = 0;
        memset(&out, 0, sizeof out);
    }
    memcpy(u_V, out.u, sizeof out.u);
    /* k, t, q[3], qd[3], (u, u_n, u_c) per joint, enable (rrr_hil_logs.h) */
    _Static_assert(RRR_HIL_CONTROLLER_LOG_COLUMNS == 2 + 3 + 3 + 3 * 3 + 1,
                   "the controller log's row (rrr_robot.hil.logs.specs)");
    if (c->log != NULL) {
        fprintf(c->log, "%zu,%.17g", k, c->ref.t[k]);
        for (int i = 0; i < 3; ++i) {
            fprintf(c->log, ",%.17g", c->q[i]);
        }
        for (int i = 0; i < 3; ++i) {
            fprintf(c->log, ",%.17g", c->qd[i]);
        }
        for (int i = 0; i < 3; ++i) {
            fprintf(c->log, ",%.17g,%.17g,%.17g", out.u[i], out.u_n[i], out.u_c[i]);
        }
        fprintf(c->log, ",%d\n", enable);
    }
    return enable;
}
