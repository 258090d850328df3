/* The frames of the CANopen master (hil_canopen_master.h). */
#include "hil_canopen_master.h"

#include "hil_canopen.h"

#include <math.h>
#include <string.h>

#define COM_PI 3.14159265358979323846

static void frame(rrr_hil_frame *f, uint32_t id, uint8_t dlc)
{
    memset(f, 0, sizeof *f);
    f->id = id;
    f->dlc = dlc;
}

void rrr_com_nmt(uint8_t command, uint8_t node, rrr_hil_frame *f)
{
    frame(f, 0x000u, 2u);
    f->data[0] = command;
    f->data[1] = node;
}

void rrr_com_sync(rrr_hil_frame *f)
{
    frame(f, 0x080u, 0u);
}

void rrr_com_heartbeat(uint8_t node, uint8_t state, rrr_hil_frame *f)
{
    frame(f, 0x700u + (node & 0x7Fu), 1u);
    f->data[0] = state;
}

static void sdo_head(rrr_hil_frame *f, uint8_t node, uint8_t cs, uint16_t index, uint8_t sub)
{
    frame(f, 0x600u + node, 8u);
    f->data[0] = cs;
    rrr_co_put_le(&f->data[1], index, 2u);
    f->data[3] = sub;
}

int rrr_com_sdo_download(uint8_t node, uint16_t index, uint8_t sub, uint32_t value,
                         unsigned size, rrr_hil_frame *f)
{
    if (node < 1u || node > 127u || (size != 1u && size != 2u && size != 4u)) {
        return -1;
    }
    /* initiate download, expedited (e = 1), size indicated (s = 1), n = 4 - size unused bytes */
    sdo_head(f, node, (uint8_t)(0x23u | ((4u - size) << 2)), index, sub);
    rrr_co_put_le(&f->data[4], value, size);
    return 0;
}

int rrr_com_sdo_upload(uint8_t node, uint16_t index, uint8_t sub, rrr_hil_frame *f)
{
    if (node < 1u || node > 127u) {
        return -1;
    }
    sdo_head(f, node, 0x40u, index, sub);
    return 0;
}

rrr_com_sdo_answer rrr_com_sdo_reply(const rrr_hil_frame *f, uint8_t node, uint16_t index,
                                     uint8_t sub, int upload, uint32_t *value)
{
    if (f->extended || f->id != 0x580u + node || f->dlc < 4u ||
        rrr_co_get_le(&f->data[1], 2u) != index || f->data[3] != sub) {
        return RRR_COM_SDO_OTHER;
    }
    const uint8_t cs = f->data[0];
    if (cs == 0x80u) {
        if (f->dlc != 8u) {
            return RRR_COM_SDO_BAD;
        }
        *value = rrr_co_get_le(&f->data[4], 4u);
        return RRR_COM_SDO_ABORT;
    }
    if (f->dlc != 8u) {
        return RRR_COM_SDO_BAD;
    }
    if (!upload) {
        return cs == 0x60u ? RRR_COM_SDO_DONE : RRR_COM_SDO_BAD;
    }
    if ((cs & 0xE3u) != 0x43u) { /* scs 2, expedited, size indicated */
        return RRR_COM_SDO_BAD;
    }
    *value = rrr_co_get_le(&f->data[4], 4u - ((cs >> 2) & 3u));
    return RRR_COM_SDO_DONE;
}

void rrr_com_rpdo1(uint8_t node, uint16_t controlword, int16_t torque_pm, rrr_hil_frame *f)
{
    frame(f, 0x200u + node, 4u);
    rrr_co_put_le(&f->data[0], controlword, 2u);
    rrr_co_put_le(&f->data[2], (uint16_t)torque_pm, 2u);
}

int rrr_com_tpdo(const rrr_hil_frame *f, uint8_t node, rrr_com_feedback *fb)
{
    if (f->extended || (f->id != 0x180u + node && f->id != 0x280u + node)) {
        return 0;
    }
    if (f->dlc != (f->id == 0x180u + node ? RRR_COM_TPDO1_DLC : RRR_COM_TPDO2_DLC)) {
        return -1;
    }
    if (f->id == 0x180u + node) {
        fb->statusword = (uint16_t)rrr_co_get_le(&f->data[0], 2u);
        fb->position_inc = (int32_t)rrr_co_get_le(&f->data[2], 4u);
        fb->have |= 1u;
    } else {
        fb->velocity_inc = (int32_t)rrr_co_get_le(&f->data[0], 4u);
        fb->have |= 2u;
    }
    return 1;
}

uint8_t rrr_com_emcy(const rrr_hil_frame *f, uint16_t *code)
{
    if (f->extended || f->id <= 0x080u || f->id > 0x0FFu || f->dlc != 8u) {
        return 0u;
    }
    *code = (uint16_t)rrr_co_get_le(&f->data[0], 2u);
    return (uint8_t)(f->id - 0x080u);
}

unsigned rrr_com_tpdo_number(const rrr_hil_frame *f, uint8_t node)
{
    if (f->extended) {
        return 0u;
    }
    return f->id == 0x180u + node ? 1u : f->id == 0x280u + node ? 2u : 0u;
}

int16_t rrr_com_torque_pm(double u_V, double kt, uint32_t rated_mNm)
{
    const double x = kt * u_V * 1e6 / (double)rated_mNm;
    if (!isfinite(x)) {
        return 0;
    }
    if (x >= 1000.0) {
        return 1000;
    }
    if (x <= -1000.0) {
        return -1000;
    }
    return (int16_t)lround(x);
}

double rrr_com_inc_to_rad(int32_t n, uint32_t increments)
{
    return (double)n * (2.0 * COM_PI) / (double)increments;
}
