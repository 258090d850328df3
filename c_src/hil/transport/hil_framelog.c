/* The frame log of a bench node (see hil_framelog.h). */
#define _POSIX_C_SOURCE 200809L

#include "hil_framelog.h"

#include <errno.h>
#include <string.h>
#include <time.h>

int rrr_hil_framelog_open(rrr_hil_framelog *l, const char *path, char *err, size_t err_len)
{
    memset(l, 0, sizeof *l);
    l->fp = fopen(path, "wb");
    if (l->fp == NULL) {
        snprintf(err, err_len, "cannot write the frame log %s: %s", path, strerror(errno));
        return -1;
    }
    /* a full buffer is written at once; a NULL buffer lets stdio allocate it (freed by fclose) */
    (void)setvbuf(l->fp, NULL, _IOFBF, RRR_HIL_FRAMELOG_BUFFER);
    if (fwrite(RRR_HIL_FRAMELOG_MAGIC, 1u, 8u, l->fp) != 8u) {
        snprintf(err, err_len, "cannot write the frame log %s: %s", path, strerror(errno));
        fclose(l->fp);
        l->fp = NULL;
        return -1;
    }
    return 0;
}

void rrr_hil_framelog_pack(uint8_t out[RRR_HIL_FRAMELOG_RECORD], int64_t t_ns,
                           const rrr_hil_frame *f, int dir)
{
    memset(out, 0, RRR_HIL_FRAMELOG_RECORD);
    const uint64_t t = (uint64_t)t_ns;
    for (unsigned i = 0; i < 8u; ++i) {
        out[i] = (uint8_t)(t >> (8u * i));
    }
    const uint32_t id = (f->id & (f->extended ? 0x1FFFFFFFu : 0x7FFu)) |
                        (f->extended ? 0x80000000u : 0u);
    for (unsigned i = 0; i < 4u; ++i) {
        out[8u + i] = (uint8_t)(id >> (8u * i));
    }
    const uint8_t dlc = f->dlc <= 8u ? f->dlc : 8u;
    out[12] = dlc;
    out[13] = (uint8_t)(dir == RRR_HIL_FRAME_TX);
    memcpy(out + 16, f->data, dlc);
}

void rrr_hil_framelog_put(rrr_hil_framelog *l, const rrr_hil_frame *f, int dir)
{
    if (l == NULL || l->fp == NULL) {
        return;
    }
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint8_t rec[RRR_HIL_FRAMELOG_RECORD];
    rrr_hil_framelog_pack(rec, (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec, f, dir);
    if (fwrite(rec, 1u, sizeof rec, l->fp) != sizeof rec) {
        if (l->error == 0) {
            l->error = errno != 0 ? errno : EIO;
        }
        return;
    }
    ++l->frames;
}

int rrr_hil_framelog_close(rrr_hil_framelog *l)
{
    if (l->fp == NULL) {
        return l->error != 0 ? -1 : 0;
    }
    if (fclose(l->fp) != 0 && l->error == 0) {
        l->error = errno != 0 ? errno : EIO;
    }
    l->fp = NULL;
    return l->error != 0 ? -1 : 0;
}
