/* What every profile's controller loop shares (hil_controller.h). */
#include "hil_controller.h"

int rrr_hil_ctrl_lost(rrr_hil_ctrl *c, const char *what, rrr_hil_io io)
{
    return rrr_hil_run_end(&c->run, RRR_HIL_EXIT_PEER_LOST, "plant lost: %s: %s%s%s", what,
                           rrr_hil_io_str(io), c->tr->last_error[0] ? ": " : "",
                           c->tr->last_error);
}

int rrr_hil_ctrl_send(rrr_hil_ctrl *c, const rrr_hil_frame *f, const char *what)
{
    const rrr_hil_io io = rrr_hil_send(c->tr, f);
    return io == RRR_HIL_IO_OK ? 0 : rrr_hil_ctrl_lost(c, what, io);
}

int rrr_hil_ctrl_recv_until(rrr_hil_ctrl *c, int64_t deadline_ms, const rrr_hil_ctrl_opts *o,
                            const char *what, rrr_hil_frame *f)
{
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return rrr_hil_run_interrupted(&c->run);
        }
        const int64_t left = deadline_ms - rrr_hil_now_ms();
        if (left <= 0) {
            return rrr_hil_run_end(&c->run, RRR_HIL_EXIT_PEER_LOST,
                                   "plant lost: no %s within %d ms (--timeout-ms)", what,
                                   o->timeout_ms);
        }
        const rrr_hil_io io = rrr_hil_recv(c->tr, f, (int)(left < 100 ? left : 100) * 1000);
        if (io == RRR_HIL_IO_OK) {
            return 0;
        }
        if (io != RRR_HIL_IO_TIMEOUT) {
            return rrr_hil_ctrl_lost(c, what, io);
        }
    }
}
