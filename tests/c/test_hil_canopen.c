/* The CANopen slave of one simulated CiA 402 axis (hil_canopen.h): NMT, SDO (expedited,
 * segmented upload, the abort codes), heartbeat producer and consumer, the 402 state machine,
 * PDOs on SYNC with their mapping rewritten by SDO, EMCY on every fault, and hostile frames. */
#include <string.h>

#include "hil_canopen.h"
#include "rrr_test.h"

#define ID 2u
#define RATED 120000u /* mN m */

static rrr_co_out out;

static rrr_co_node booted(void)
{
    rrr_co_node n;
    const rrr_co_config cfg = {ID, RATED};
    CHECK(rrr_co_init(&n, &cfg) == 0);
    out.n = 0;
    rrr_co_boot(&n, &out);
    return n;
}

static rrr_hil_frame frame(uint32_t id, uint8_t dlc, const uint8_t *data)
{
    rrr_hil_frame f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = dlc;
    if (data) {
        memcpy(f.data, data, dlc);
    }
    return f;
}

static void feed(rrr_co_node *n, uint32_t id, uint8_t dlc, const uint8_t *data)
{
    const rrr_hil_frame f = frame(id, dlc, data);
    out.n = 0;
    rrr_co_on_frame(n, &f, &out);
}

static void nmt(rrr_co_node *n, uint8_t cs, uint8_t node)
{
    const uint8_t d[2] = {cs, node};
    feed(n, 0x000, 2, d);
}

static uint32_t le(const uint8_t *p, unsigned k)
{
    uint32_t v = 0;
    for (unsigned i = 0; i < k; ++i) {
        v |= (uint32_t)p[i] << (8u * i);
    }
    return v;
}

/* The one SDO response in out: its abort code (0 if not an abort), *value for an upload. */
static uint32_t sdo_reply(uint16_t index, uint8_t sub, uint32_t *value)
{
    const rrr_hil_frame *r = NULL;
    unsigned count = 0;
    for (unsigned i = 0; i < out.n; ++i) {
        if (out.f[i].id == 0x580u + ID) {
            r = &out.f[i];
            count++;
        }
    }
    CHECK(count == 1); /* one SDO response (an EMCY may come with it) */
    if (count != 1) {
        return 0xFFFFFFFFu;
    }
    CHECK(r->dlc == 8);
    CHECK(le(r->data + 1, 2) == index && r->data[3] == sub);
    if (r->data[0] == 0x80) {
        return le(r->data + 4, 4);
    }
    if (value) {
        const unsigned size = 4u - ((r->data[0] >> 2) & 3u);
        CHECK((r->data[0] & 0xE3u) == 0x43u); /* expedited upload, size indicated */
        *value = le(r->data + 4, size);
    } else {
        CHECK(r->data[0] == 0x60);
    }
    return 0;
}

static uint32_t sdo_read(rrr_co_node *n, uint16_t index, uint8_t sub, uint32_t *value)
{
    const uint8_t d[8] = {0x40, (uint8_t)index, (uint8_t)(index >> 8), sub, 0, 0, 0, 0};
    feed(n, 0x600u + ID, 8, d);
    return sdo_reply(index, sub, value);
}

static uint32_t sdo_write(rrr_co_node *n, uint16_t index, uint8_t sub, uint32_t v, unsigned size)
{
    uint8_t d[8] = {(uint8_t)(0x23u | ((4u - size) << 2)), (uint8_t)index, (uint8_t)(index >> 8),
                    sub, 0, 0, 0, 0};
    for (unsigned i = 0; i < size; ++i) {
        d[4 + i] = (uint8_t)(v >> (8u * i));
    }
    feed(n, 0x600u + ID, 8, d);
    return sdo_reply(index, sub, NULL);
}

static const rrr_hil_frame *find_out(uint32_t id)
{
    for (unsigned i = 0; i < out.n; ++i) {
        if (out.f[i].id == id) {
            return &out.f[i];
        }
    }
    return NULL;
}

/* An EMCY in out with this code and error register. */
static int has_emcy(uint16_t code, uint8_t reg)
{
    const rrr_hil_frame *e = find_out(0x80u + ID);
    return e && e->dlc == 8 && le(e->data, 2) == code && e->data[2] == reg;
}

static void sync(rrr_co_node *n)
{
    feed(n, 0x080, 0, NULL);
    rrr_co_transmit(n, &out);
}

static void rpdo(rrr_co_node *n, uint16_t cw, int16_t torque)
{
    const uint8_t d[4] = {(uint8_t)cw, (uint8_t)(cw >> 8), (uint8_t)(uint16_t)torque,
                          (uint8_t)((uint16_t)torque >> 8)};
    feed(n, 0x200u + ID, 4, d);
}

/* A node in NMT operational and OPERATION ENABLED (controlwords by SDO). */
static rrr_co_node enabled(void)
{
    rrr_co_node n = booted();
    nmt(&n, 0x01, 0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x06, 2) == 0 && n.s402 == RRR_CO_402_READY);
    CHECK(sdo_write(&n, 0x6040, 0, 0x07, 2) == 0 && n.s402 == RRR_CO_402_SWITCHED_ON);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0 && n.s402 == RRR_CO_402_OPERATION_ENABLED);
    return n;
}

static void test_boot_and_nmt(void)
{
    rrr_co_node n;
    const rrr_co_config bad = {0, RATED}, bad2 = {128, RATED}, bad3 = {1, 0};
    CHECK(rrr_co_init(&n, &bad) == -1 && rrr_co_init(&n, &bad2) == -1);
    CHECK(rrr_co_init(&n, &bad3) == -1 && rrr_co_init(NULL, &bad) == -1);
    n = booted();
    CHECK(out.n == 1 && out.f[0].id == 0x702 && out.f[0].dlc == 1 && out.f[0].data[0] == 0);
    CHECK(n.nmt == RRR_CO_NMT_PREOPERATIONAL && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x6041, 0, &v) == 0 && v == 0x0240u);
    nmt(&n, 0x01, 3); /* another node */
    CHECK(n.nmt == RRR_CO_NMT_PREOPERATIONAL);
    nmt(&n, 0x01, ID);
    CHECK(n.nmt == RRR_CO_NMT_OPERATIONAL);
    nmt(&n, 0x02, 0);
    CHECK(n.nmt == RRR_CO_NMT_STOPPED && out.n == 0);
    /* stopped: no SDO answer */
    const uint8_t rd[8] = {0x40, 0x00, 0x10, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, rd);
    CHECK(out.n == 0);
    nmt(&n, 0x80, 0);
    CHECK(n.nmt == RRR_CO_NMT_PREOPERATIONAL);
    /* wrong DLC, unknown command: ignored and counted */
    const uint8_t d3[3] = {0x01, 0x00, 0x00};
    feed(&n, 0x000, 3, d3);
    CHECK(n.nmt == RRR_CO_NMT_PREOPERATIONAL && n.err.nmt_ignored == 1);
    nmt(&n, 0x07, 0);
    CHECK(n.nmt == RRR_CO_NMT_PREOPERATIONAL && n.err.nmt_ignored == 2);
    /* reset communication: the communication area only, and a boot-up */
    CHECK(sdo_write(&n, 0x1017, 0, 250, 2) == 0 && sdo_write(&n, 0x2001, 0, 7, 1) == 0);
    nmt(&n, 0x01, 0);
    nmt(&n, 0x82, ID);
    CHECK(out.n == 1 && out.f[0].id == 0x702 && out.f[0].data[0] == 0);
    CHECK(n.nmt == RRR_CO_NMT_PREOPERATIONAL);
    CHECK(sdo_read(&n, 0x1017, 0, &v) == 0 && v == 100);
    CHECK(sdo_read(&n, 0x2001, 0, &v) == 0 && v == 7);
    /* reset node: everything */
    nmt(&n, 0x81, 0);
    CHECK(out.n == 1 && out.f[0].id == 0x702 && out.f[0].data[0] == 0);
    CHECK(sdo_read(&n, 0x2001, 0, &v) == 0 && v == 3);
}

static void test_sdo(void)
{
    rrr_co_node n = booted();
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x1000, 0, &v) == 0 && v == 0x00020192u);
    CHECK(sdo_read(&n, 0x1018, 0, &v) == 0 && v == 4);
    CHECK(sdo_read(&n, 0x1018, 4, &v) == 0 && v == ID); /* serial = node id */
    CHECK(sdo_read(&n, 0x1400, 1, &v) == 0 && v == 0x200u + ID);
    CHECK(sdo_read(&n, 0x1A00, 1, &v) == 0 && v == 0x60410010u);
    CHECK(sdo_read(&n, 0x6076, 0, &v) == 0 && v == RATED);
    CHECK(sdo_read(&n, 0x608F, 1, &v) == 0 && v == (1u << 20));
    CHECK(sdo_read(&n, 0x6060, 0, &v) == 0 && v == 10);
    CHECK(sdo_read(&n, 0x6502, 0, &v) == 0 && v == (1u << 9));
    /* the standard abort codes */
    CHECK(sdo_read(&n, 0x1234, 0, &v) == RRR_CO_ABORT_NO_OBJECT);
    CHECK(sdo_read(&n, 0x1018, 9, &v) == RRR_CO_ABORT_NO_SUB);
    CHECK(sdo_read(&n, 0x6041, 1, &v) == RRR_CO_ABORT_NO_SUB);
    CHECK(sdo_read(&n, 0x2000, 0, &v) == RRR_CO_ABORT_WRITE_ONLY);
    CHECK(sdo_write(&n, 0x6041, 0, 1, 2) == RRR_CO_ABORT_READ_ONLY);
    CHECK(sdo_write(&n, 0x1000, 0, 1, 4) == RRR_CO_ABORT_READ_ONLY);
    CHECK(sdo_write(&n, 0x1008, 0, 1, 4) == RRR_CO_ABORT_READ_ONLY);
    CHECK(sdo_write(&n, 0x1017, 0, 100, 4) == RRR_CO_ABORT_LEN_HIGH);
    CHECK(sdo_write(&n, 0x1017, 0, 100, 1) == RRR_CO_ABORT_LEN_LOW);
    CHECK(sdo_write(&n, 0x6071, 0, 1001, 2) == RRR_CO_ABORT_TOO_HIGH);
    CHECK(sdo_write(&n, 0x6071, 0, (uint16_t)-1001, 2) == RRR_CO_ABORT_TOO_LOW);
    CHECK(sdo_write(&n, 0x6071, 0, (uint16_t)-1000, 2) == 0);
    CHECK(sdo_read(&n, 0x6071, 0, &v) == 0 && v == 0xFC18u);
    CHECK(sdo_write(&n, 0x6060, 0, 9, 1) == RRR_CO_ABORT_TOO_LOW);
    CHECK(sdo_write(&n, 0x2000, 0, 0, 2) == RRR_CO_ABORT_TOO_LOW);
    CHECK(sdo_write(&n, 0x1800, 2, 0, 1) == RRR_CO_ABORT_TOO_LOW); /* TPDO: types 1..240 */
    CHECK(sdo_write(&n, 0x1400, 2, 250, 1) == RRR_CO_ABORT_VALUE); /* RPDO: 0..240, 254, 255 */
    CHECK(sdo_write(&n, 0x1400, 2, 255, 1) == 0);
    /* expedited download without a size: the object's size */
    const uint8_t nosize[8] = {0x22, 0x17, 0x10, 0, 0xC8, 0, 0xAA, 0xAA};
    feed(&n, 0x602, 8, nosize);
    CHECK(sdo_reply(0x1017, 0, NULL) == 0 && n.v[RRR_CO_OD_HB_PRODUCER] == 200);
    /* segmented download: size given and right, one segment of 2 bytes (n = 5, c = 1) */
    const uint8_t seg_ok[8] = {0x21, 0x17, 0x10, 0, 2, 0, 0, 0};
    feed(&n, 0x602, 8, seg_ok);
    CHECK(sdo_reply(0x1017, 0, NULL) == 0 && n.dl_active);
    const uint8_t seg1[8] = {0x0B, 0x2C, 0x01, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, seg1);
    CHECK(out.n == 1 && out.f[0].data[0] == 0x20 && !n.dl_active);
    CHECK(n.v[RRR_CO_OD_HB_PRODUCER] == 300);
    /* size not given, two segments (1 byte, then 1 byte and the end), toggling */
    const uint8_t seg_ns[8] = {0x20, 0x16, 0x10, 1, 0, 0, 0, 0};
    feed(&n, 0x602, 8, seg_ns);
    CHECK(sdo_reply(0x1016, 1, NULL) == 0);
    const uint8_t s_a[8] = {0x0C, 0x64, 0, 0, 0, 0, 0, 0};  /* t 0, n 6 */
    const uint8_t s_b[8] = {0x1C, 0x00, 0, 0, 0, 0, 0, 0};  /* t 1, n 6 */
    const uint8_t s_c[8] = {0x0B, 0x7F, 0x00, 0, 0, 0, 0, 0}; /* t 0, n 5, last */
    feed(&n, 0x602, 8, s_a);
    CHECK(out.n == 1 && out.f[0].data[0] == 0x20);
    feed(&n, 0x602, 8, s_b);
    CHECK(out.n == 1 && out.f[0].data[0] == 0x30);
    feed(&n, 0x602, 8, s_c);
    CHECK(out.n == 1 && out.f[0].data[0] == 0x20 && n.v[RRR_CO_OD_HB_CONSUMER_1] == 0x007F0064u);
    /* a repeated toggle bit, too many bytes, too few at the end, a value a write refuses */
    feed(&n, 0x602, 8, seg_ns);
    feed(&n, 0x602, 8, s_a);
    feed(&n, 0x602, 8, s_a);
    CHECK(sdo_reply(0x1016, 1, NULL) == RRR_CO_ABORT_TOGGLE && !n.dl_active);
    feed(&n, 0x602, 8, seg_ok);
    const uint8_t s_long[8] = {0x06, 1, 2, 3, 0, 0, 0, 0}; /* 4 bytes into 2 */
    feed(&n, 0x602, 8, s_long);
    CHECK(sdo_reply(0x1017, 0, NULL) == RRR_CO_ABORT_LEN_HIGH);
    feed(&n, 0x602, 8, seg_ok);
    const uint8_t s_short[8] = {0x0D, 1, 0, 0, 0, 0, 0, 0}; /* 1 byte, last */
    feed(&n, 0x602, 8, s_short);
    CHECK(sdo_reply(0x1017, 0, NULL) == RRR_CO_ABORT_LEN_LOW && n.v[RRR_CO_OD_HB_PRODUCER] == 300);
    const uint8_t seg_tq[8] = {0x21, 0x71, 0x60, 0, 2, 0, 0, 0};
    feed(&n, 0x602, 8, seg_tq);
    const uint8_t s_tq[8] = {0x0B, 0xD0, 0x07, 0, 0, 0, 0, 0}; /* 2000 per mille */
    feed(&n, 0x602, 8, s_tq);
    CHECK(sdo_reply(0x6071, 0, NULL) == RRR_CO_ABORT_TOO_HIGH);
    /* read-only, wrong size at the start */
    const uint8_t seg_ro[8] = {0x21, 0x41, 0x60, 0, 2, 0, 0, 0};
    feed(&n, 0x602, 8, seg_ro);
    CHECK(sdo_reply(0x6041, 0, NULL) == RRR_CO_ABORT_READ_ONLY);
    const uint8_t seg_bad[8] = {0x21, 0x17, 0x10, 0, 9, 0, 0, 0};
    feed(&n, 0x602, 8, seg_bad);
    CHECK(sdo_reply(0x1017, 0, NULL) == RRR_CO_ABORT_LEN_HIGH);
    /* bad command specifiers: block upload (5), block download (6), 7, a lone segment */
    const uint8_t ccs[4] = {0xA0, 0xC0, 0xE0, 0x00};
    for (unsigned i = 0; i < 4; ++i) {
        const uint8_t d[8] = {ccs[i], 0x00, 0x10, 0, 0, 0, 0, 0};
        feed(&n, 0x602, 8, d);
        CHECK(sdo_reply(0x1000, 0, NULL) == RRR_CO_ABORT_CS);
    }
    const uint8_t lone_up[8] = {0x60, 0, 0, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, lone_up);
    CHECK(sdo_reply(0, 0, NULL) == RRR_CO_ABORT_CS);
    /* wrong DLC: an abort, nothing read or written */
    const uint8_t shortw[5] = {0x2F, 0x01, 0x20, 0, 9};
    feed(&n, 0x602, 5, shortw);
    CHECK(sdo_reply(0x2001, 0, NULL) == RRR_CO_ABORT_CS && n.v[RRR_CO_OD_RPDO_TIMEOUT] == 3);
    feed(&n, 0x602, 0, NULL);
    CHECK(sdo_reply(0, 0, NULL) == RRR_CO_ABORT_CS);
    /* another node's SDO and extended frames: ignored */
    feed(&n, 0x603, 8, lone_up);
    CHECK(out.n == 0);
    rrr_hil_frame ext = frame(0x602, 8, lone_up);
    ext.extended = 1;
    out.n = 0;
    rrr_co_on_frame(&n, &ext, &out);
    CHECK(out.n == 0);
}

static void test_segmented_upload(void)
{
    rrr_co_node n = booted();
    const char *name = "RRR simulated CiA 402 axis";
    const uint8_t init[8] = {0x40, 0x08, 0x10, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, init);
    CHECK(out.n == 1 && out.f[0].data[0] == 0x41 && le(out.f[0].data + 4, 4) == strlen(name));
    char got[64] = {0};
    unsigned len = 0, toggle = 0, done = 0;
    for (int k = 0; k < 10 && !done; ++k) {
        const uint8_t seg[8] = {(uint8_t)(0x60u | (toggle << 4)), 0, 0, 0, 0, 0, 0, 0};
        feed(&n, 0x602, 8, seg);
        CHECK(out.n == 1 && ((out.f[0].data[0] >> 4) & 1u) == toggle);
        const unsigned kk = 7u - ((out.f[0].data[0] >> 1) & 7u);
        memcpy(got + len, out.f[0].data + 1, kk);
        len += kk;
        done = out.f[0].data[0] & 1u;
        toggle ^= 1u;
    }
    CHECK(done && len == strlen(name) && strcmp(got, name) == 0);
    /* a wrong toggle bit aborts */
    feed(&n, 0x602, 8, init);
    const uint8_t seg1[8] = {0x70, 0, 0, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, seg1);
    CHECK(sdo_reply(0x1008, 0, NULL) == RRR_CO_ABORT_TOGGLE && !n.seg_active);
}

/* The SDO server's timeout: a segmented transfer without a request for RRR_CO_SDO_TIMEOUT_US
 * of rrr_co_advance's time is aborted with 0x05040000; every request restarts the time. */
static void test_sdo_timeout(void)
{
    rrr_co_node n = booted();
    CHECK(sdo_write(&n, 0x1017, 0, 0, 2) == 0); /* no heartbeat frames in out */
    const uint8_t init[8] = {0x40, 0x08, 0x10, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, init);
    CHECK(n.seg_active);
    out.n = 0;
    rrr_co_advance(&n, RRR_CO_SDO_TIMEOUT_US - 1u, &out);
    CHECK(out.n == 0 && n.seg_active);
    const uint8_t seg0[8] = {0x60, 0, 0, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, seg0); /* a request: the time starts again */
    CHECK(out.n == 1 && n.seg_active);
    out.n = 0;
    rrr_co_advance(&n, RRR_CO_SDO_TIMEOUT_US / 2u, &out);
    rrr_co_advance(&n, RRR_CO_SDO_TIMEOUT_US / 2u, &out); /* exactly the timeout: not beyond */
    CHECK(out.n == 0 && n.seg_active && n.err.sdo_timeouts == 0);
    const uint32_t aborts = n.err.sdo_aborts;
    rrr_co_advance(&n, 1, &out);
    CHECK(sdo_reply(0x1008, 0, NULL) == RRR_CO_ABORT_TIMEOUT);
    CHECK(!n.seg_active && n.err.sdo_timeouts == 1 && n.err.sdo_aborts == aborts + 1u);
    out.n = 0;
    rrr_co_advance(&n, RRR_CO_SDO_TIMEOUT_US * 3u, &out); /* nothing in progress: nothing */
    CHECK(out.n == 0 && n.err.sdo_timeouts == 1);
    const uint8_t seg1[8] = {0x70, 0, 0, 0, 0, 0, 0, 0};
    feed(&n, 0x602, 8, seg1); /* the transfer is gone: a segment is out of place */
    CHECK(sdo_reply(0, 0, NULL) == RRR_CO_ABORT_CS);
    /* a segmented download left hanging, and one huge step of time (no overflow) */
    const uint8_t dl[8] = {0x21, 0x17, 0x10, 0, 2, 0, 0, 0};
    feed(&n, 0x602, 8, dl);
    CHECK(sdo_reply(0x1017, 0, NULL) == 0 && n.dl_active);
    out.n = 0;
    rrr_co_advance(&n, RRR_CO_SDO_TIMEOUT_US - 10u, &out);
    rrr_co_advance(&n, UINT32_MAX, &out);
    CHECK(sdo_reply(0x1017, 0, NULL) == RRR_CO_ABORT_TIMEOUT);
    CHECK(!n.dl_active && n.err.sdo_timeouts == 2 && n.v[RRR_CO_OD_HB_PRODUCER] == 0);
}

static void test_402(void)
{
    rrr_co_node n = booted();
    /* torque only in NMT operational and OPERATION ENABLED */
    CHECK(sdo_write(&n, 0x6071, 0, 500, 2) == 0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    CHECK(sdo_write(&n, 0x6040, 0, 0x06, 2) == 0 && n.s402 == RRR_CO_402_READY);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0 && n.s402 == RRR_CO_402_OPERATION_ENABLED);
    CHECK(rrr_co_torque_Nm(&n) == 0.0); /* pre-operational */
    nmt(&n, 0x01, 0);
    CHECK_CLOSE(rrr_co_torque_Nm(&n), 60.0, 1e-12);
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x6041, 0, &v) == 0 && (v & 0x6Fu) == 0x27u);
    /* disable operation, enable, quick stop, enable from quick stop, disable voltage */
    CHECK(sdo_write(&n, 0x6040, 0, 0x07, 2) == 0 && n.s402 == RRR_CO_402_SWITCHED_ON);
    CHECK(rrr_co_torque_Nm(&n) == 0.0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0 && n.s402 == RRR_CO_402_OPERATION_ENABLED);
    CHECK(sdo_write(&n, 0x6040, 0, 0x02, 2) == 0 && n.s402 == RRR_CO_402_QUICK_STOP);
    CHECK(rrr_co_torque_Nm(&n) == 0.0);
    CHECK(sdo_read(&n, 0x6041, 0, &v) == 0 && (v & 0x6Fu) == 0x07u);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0 && n.s402 == RRR_CO_402_OPERATION_ENABLED);
    CHECK(sdo_write(&n, 0x6040, 0, 0x00, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    /* quick stop from READY goes to SWITCH ON DISABLED */
    CHECK(sdo_write(&n, 0x6040, 0, 0x06, 2) == 0 && n.s402 == RRR_CO_402_READY);
    CHECK(sdo_write(&n, 0x6040, 0, 0x02, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    /* a fault (simulated, 0x2000): FAULT, EMCY with 0x1001 and 0x603F */
    CHECK(sdo_write(&n, 0x6040, 0, 0x80, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    CHECK(sdo_write(&n, 0x2000, 0, 0x5530, 2) == 0);
    CHECK(out.n == 2 && has_emcy(0x5530, 0x81) && n.s402 == RRR_CO_402_FAULT);
    CHECK(sdo_read(&n, 0x1001, 0, &v) == 0 && v == 0x81);
    CHECK(sdo_read(&n, 0x603F, 0, &v) == 0 && v == 0x5530);
    CHECK(sdo_read(&n, 0x6041, 0, &v) == 0 && (v & 0x4Fu) == 0x08u);
    /* bit 7 already high: no edge, no reset; other commands are ignored in FAULT */
    CHECK(sdo_write(&n, 0x6040, 0, 0x80, 2) == 0 && n.s402 == RRR_CO_402_FAULT);
    CHECK(sdo_write(&n, 0x6040, 0, 0x06, 2) == 0 && n.s402 == RRR_CO_402_FAULT);
    CHECK(sdo_write(&n, 0x6040, 0, 0x86, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    CHECK(has_emcy(0x0000, 0x00) && n.latch.resets == 1 && n.latch.fault_events == 1);
    CHECK(sdo_read(&n, 0x1001, 0, &v) == 0 && v == 0);
    CHECK(sdo_read(&n, 0x603F, 0, &v) == 0 && v == 0);
    CHECK(strcmp(rrr_co_402_str(RRR_CO_402_OPERATION_ENABLED), "OPERATION ENABLED") == 0);
    /* NMT stop while enabled: EMCY 0x8100 (sent before stopping), FAULT */
    rrr_co_node m = enabled();
    nmt(&m, 0x02, 0);
    CHECK(has_emcy(RRR_CO_EMCY_COMM, 0x11) && m.s402 == RRR_CO_402_FAULT);
    CHECK(m.nmt == RRR_CO_NMT_STOPPED);
    rrr_co_raise_fault(&m, 0x8140, RRR_CO_ERR_COMM, &out);
    CHECK(m.latch.fault_events == 2); /* counted; no EMCY in stopped */
}

static void test_pdo_on_sync(void)
{
    rrr_co_node n = booted();
    nmt(&n, 0x01, 0);
    rrr_co_set_feedback(&n, 3.14159265358979323846, -2.0 * 3.14159265358979323846);
    /* the controlwords by RPDO: each acts at the next SYNC */
    const uint16_t cws[3] = {0x06, 0x07, 0x0F};
    const rrr_co_402 st[3] = {RRR_CO_402_READY, RRR_CO_402_SWITCHED_ON,
                              RRR_CO_402_OPERATION_ENABLED};
    for (unsigned i = 0; i < 3; ++i) {
        rpdo(&n, cws[i], 0);
        CHECK(out.n == 0 && n.s402 == (i == 0 ? RRR_CO_402_SWITCH_ON_DISABLED : st[i - 1]));
        sync(&n);
        CHECK(n.s402 == st[i]);
    }
    const rrr_hil_frame *t1 = find_out(0x182), *t2 = find_out(0x282);
    CHECK(out.n == 2 && t1 && t2 && t1->dlc == 7 && t2->dlc == 6);
    if (t1 && t2) {
        CHECK(le(t1->data, 2) == 0x0237u);
        CHECK(le(t1->data + 2, 4) == (1u << 19));            /* pi rad: half a revolution */
        CHECK(t1->data[6] == RRR_CO_MODE_CST);               /* 0x6061: the mode displayed */
        CHECK((int32_t)le(t2->data, 4) == -(1 << 20));       /* -2 pi rad/s */
        CHECK(le(t2->data + 4, 2) == 0);
    }
    /* 200 periods of torque: applied from the SYNC after the RPDO, reported in 0x6077 */
    for (int k = 0; k < 200; ++k) {
        const int16_t tq = (int16_t)((k * 37) % 2001 - 1000);
        rpdo(&n, 0x0F, tq);
        sync(&n);
        CHECK_CLOSE(rrr_co_torque_Nm(&n), tq * (RATED * 1e-6), 1e-9);
        t2 = find_out(0x282);
        CHECK(t2 && (int16_t)le(t2->data + 4, 2) == tq);
    }
    CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED && n.latch.fault_events == 0);
    /* the SYNC applies, rrr_co_transmit samples what the caller set in between, once */
    rpdo(&n, 0x0F, 250);
    feed(&n, 0x080, 0, NULL);
    CHECK(out.n == 0 && n.tx_pending);
    CHECK_CLOSE(rrr_co_torque_Nm(&n), 250 * (RATED * 1e-6), 1e-9);
    rrr_co_set_feedback(&n, -3.14159265358979323846 / 2.0, 0.0);
    rrr_co_transmit(&n, &out);
    t1 = find_out(0x182);
    CHECK(out.n == 2 && t1 && (int32_t)le(t1->data + 2, 4) == -(1 << 18));
    out.n = 0;
    rrr_co_transmit(&n, &out);
    CHECK(out.n == 0);
    /* a short RPDO: EMCY 0x8210, not applied (no fault) */
    const uint8_t d3[3] = {0x0F, 0, 0x10};
    feed(&n, 0x202, 3, d3);
    CHECK(has_emcy(RRR_CO_EMCY_PDO_LENGTH, 0x00) && n.err.rpdo_short == 1);
    /* a target torque out of range: FAULT, EMCY 0x6320, 0 torque */
    rpdo(&n, 0x0F, 1500);
    sync(&n);
    CHECK(has_emcy(RRR_CO_EMCY_PARAM, 0x21) && n.s402 == RRR_CO_402_FAULT);
    CHECK(rrr_co_torque_Nm(&n) == 0.0);
    /* the fault reset by RPDO (rising edge of bit 7), then enable again */
    rpdo(&n, 0x80, 0);
    sync(&n);
    CHECK(n.s402 == RRR_CO_402_SWITCH_ON_DISABLED && has_emcy(0, 0));
    /* pre-operational: no PDOs */
    nmt(&n, 0x80, 0);
    sync(&n);
    CHECK(out.n == 0);
}

static void test_rpdo_timeout(void)
{
    rrr_co_node n = enabled();
    rpdo(&n, 0x0F, 100);
    sync(&n);
    sync(&n);
    sync(&n);
    CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED); /* 2 SYNCs without an RPDO */
    sync(&n);
    CHECK(n.s402 == RRR_CO_402_FAULT && has_emcy(RRR_CO_EMCY_RPDO_TIMEOUT, 0x11));
    CHECK(n.err.rpdo_timeouts == 1);
    /* 0x2001 = 0: no timeout */
    rrr_co_node m = enabled();
    CHECK(sdo_write(&m, 0x2001, 0, 0, 1) == 0);
    for (int k = 0; k < 50; ++k) {
        sync(&m);
    }
    CHECK(m.s402 == RRR_CO_402_OPERATION_ENABLED);
}

static void test_heartbeat(void)
{
    rrr_co_node n = booted();
    out.n = 0;
    rrr_co_advance(&n, 99000, &out);
    CHECK(out.n == 0);
    rrr_co_advance(&n, 1000, &out);
    CHECK(out.n == 1 && out.f[0].id == 0x702 && out.f[0].data[0] == 0x7F);
    /* consumer of node 1, 50 ms; monitoring starts with the first heartbeat */
    CHECK(sdo_write(&n, 0x1016, 1, (1u << 16) | 50u, 4) == 0);
    CHECK(sdo_write(&n, 0x1017, 0, 0, 2) == 0); /* producer off */
    out.n = 0;
    rrr_co_advance(&n, 1000000, &out);
    CHECK(out.n == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    const uint8_t op[1] = {0x05};
    feed(&n, 0x701, 1, op);
    out.n = 0;
    rrr_co_advance(&n, 40000, &out);
    feed(&n, 0x701, 1, op);
    out.n = 0;
    rrr_co_advance(&n, 50000, &out);
    CHECK(out.n == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    rrr_co_advance(&n, 1000, &out);
    CHECK(n.s402 == RRR_CO_402_FAULT && has_emcy(RRR_CO_EMCY_HEARTBEAT, 0x11));
    CHECK(n.err.hb_lost == 1);
    out.n = 0;
    rrr_co_advance(&n, 1000000, &out); /* lost once: one fault */
    CHECK(out.n == 0 && n.err.hb_lost == 1);
}

static void test_mapping_by_sdo(void)
{
    rrr_co_node n = booted();
    /* the PDO must be invalid, and sub 0 = 0, to change the mapping */
    CHECK(sdo_write(&n, 0x1A00, 0, 0, 1) == RRR_CO_ABORT_UNSUPPORTED);
    CHECK(sdo_write(&n, 0x1800, 1, 0x183, 4) == RRR_CO_ABORT_VALUE); /* id while valid */
    CHECK(sdo_write(&n, 0x1800, 1, 0xA0000182u, 4) == RRR_CO_ABORT_VALUE); /* 29-bit */
    CHECK(sdo_write(&n, 0x1800, 1, 0x80000182u, 4) == 0);
    CHECK(sdo_write(&n, 0x1A00, 1, 0x60770010u, 4) == RRR_CO_ABORT_UNSUPPORTED); /* sub0 != 0 */
    CHECK(sdo_write(&n, 0x1A00, 0, 0, 1) == 0);
    CHECK(sdo_write(&n, 0x1A00, 1, 0x10000020u, 4) == RRR_CO_ABORT_NO_MAP); /* not mappable */
    CHECK(sdo_write(&n, 0x1A00, 1, 0x60410020u, 4) == RRR_CO_ABORT_NO_MAP); /* wrong length */
    CHECK(sdo_write(&n, 0x1A00, 1, 0x20000010u, 4) == RRR_CO_ABORT_NO_MAP); /* write-only */
    CHECK(sdo_write(&n, 0x1A00, 1, 0x60640020u, 4) == 0);
    CHECK(sdo_write(&n, 0x1A00, 2, 0x606C0020u, 4) == 0);
    CHECK(sdo_write(&n, 0x1A00, 3, 0x60410010u, 4) == 0);
    CHECK(sdo_write(&n, 0x1A00, 0, 3, 1) == RRR_CO_ABORT_MAP_LEN);  /* 80 bits */
    CHECK(sdo_write(&n, 0x1A00, 0, 5, 1) == RRR_CO_ABORT_TOO_HIGH);
    CHECK(sdo_write(&n, 0x1A00, 0, 2, 1) == 0);
    CHECK(sdo_write(&n, 0x1800, 2, 2, 1) == 0); /* every 2nd SYNC */
    CHECK(sdo_write(&n, 0x1800, 1, 0x00000190u, 4) == 0); /* a new id, valid */
    /* RPDO: a read-only object cannot be mapped */
    CHECK(sdo_write(&n, 0x1400, 1, 0x80000202u, 4) == 0);
    CHECK(sdo_write(&n, 0x1600, 0, 0, 1) == 0);
    CHECK(sdo_write(&n, 0x1600, 1, 0x60410010u, 4) == RRR_CO_ABORT_NO_MAP);
    CHECK(sdo_write(&n, 0x1600, 1, 0x60710010u, 4) == 0);
    CHECK(sdo_write(&n, 0x1600, 0, 1, 1) == 0);
    CHECK(sdo_write(&n, 0x1400, 1, 0x00000202u, 4) == 0);
    nmt(&n, 0x01, 0);
    rrr_co_set_feedback(&n, 1.0, 2.0);
    sync(&n);
    CHECK(find_out(0x190) == NULL && find_out(0x282) != NULL);
    sync(&n);
    const rrr_hil_frame *t = find_out(0x190);
    CHECK(t && t->dlc == 8);
    if (t) {
        CHECK((int32_t)le(t->data, 4) == rrr_co_rad_to_inc(1.0, 1u << 20));
        CHECK((int32_t)le(t->data + 4, 4) == rrr_co_rad_to_inc(2.0, 1u << 20));
    }
    CHECK(rrr_co_rad_to_inc(1.0, 1u << 20) == 166886); /* 2^20 / (2 pi), rounded */
    CHECK(rrr_co_rad_to_inc(1e30, 1u << 20) == INT32_MAX);
    CHECK(rrr_co_rad_to_inc(-1e30, 1u << 20) == INT32_MIN);
    CHECK(rrr_co_rad_to_inc((double)NAN, 1u << 20) == 0);
    /* the RPDO is now the torque alone (2 bytes); the controlword by SDO */
    CHECK(sdo_write(&n, 0x6040, 0, 0x06, 2) == 0 && sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0);
    const uint8_t d2[2] = {0xF4, 0x01};
    feed(&n, 0x202, 2, d2);
    sync(&n);
    CHECK_CLOSE(rrr_co_torque_Nm(&n), 500 * (RATED * 1e-6), 1e-9);
    /* a TPDO with nothing mapped is not sent */
    CHECK(sdo_write(&n, 0x1801, 1, 0x80000282u, 4) == 0 && sdo_write(&n, 0x1A01, 0, 0, 1) == 0);
    CHECK(sdo_write(&n, 0x1801, 1, 0x00000282u, 4) == 0);
    sync(&n);
    CHECK(find_out(0x282) == NULL);
    /* reset communication restores the mapping */
    nmt(&n, 0x82, 0);
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x1A00, 1, &v) == 0 && v == 0x60410010u);
    CHECK(sdo_read(&n, 0x1600, 0, &v) == 0 && v == 2);
}

/* CiA 301's restricted CAN-IDs and the predefined connection set's broadcast objects (SYNC,
 * EMCY, TIME): no PDO may be valid on one of them. */
static int restricted_id(uint32_t id)
{
    return id <= 0x180u || (id >= 0x581u && id <= 0x5FFu) || (id >= 0x601u && id <= 0x67Fu) ||
           (id >= 0x6E0u && id <= 0x6FFu) || id >= 0x701u;
}

/* The COB-ID rules of every PDO (0x1400, 0x1800, 0x1801 sub 1), each an abort 0x06090030 that
 * changes nothing: a valid PDO on a restricted identifier (every one of the 2048 is tried, as the
 * conformance test does), a change of the identifier while the PDO is valid, a 29-bit identifier
 * (bit 29) and bits 11..28 set; a restricted identifier is accepted while the PDO is invalid
 * (bit 31), and never sent or received on. */
static void test_cob_id_rules(void)
{
    static const uint16_t comm[3] = {0x1400u, 0x1800u, 0x1801u};
    static const uint32_t cob[3] = {0x200u + ID, 0x180u + ID, 0x280u + ID};
    for (unsigned p = 0; p < 3; ++p) {
        rrr_co_node n = booted();
        unsigned refused = 0;
        for (uint32_t id = 0; id <= 0x7FFu; ++id) {
            CHECK(sdo_write(&n, comm[p], 1, 0x80000000u | id, 4) == 0); /* invalid: any id */
            const uint32_t ab = sdo_write(&n, comm[p], 1, id, 4);
            if (restricted_id(id)) {
                refused++;
                CHECK(ab == RRR_CO_ABORT_VALUE);
                uint32_t v = 0;
                CHECK(sdo_read(&n, comm[p], 1, &v) == 0 && v == (0x80000000u | id));
            } else {
                CHECK(ab == 0);
            }
        }
        CHECK(refused == 0x181u + 0x7Fu + 0x7Fu + 0x20u + 0xFFu); /* 926 identifiers */
        CHECK(sdo_write(&n, comm[p], 1, 0x80000000u | cob[p], 4) == 0);
        CHECK(sdo_write(&n, comm[p], 1, cob[p], 4) == 0);
        /* the identifier changes only while the PDO is invalid */
        CHECK(sdo_write(&n, comm[p], 1, cob[p] + 0x10u, 4) == RRR_CO_ABORT_VALUE);
        /* 29-bit identifiers and bits 11..28: refused, valid or not */
        CHECK(sdo_write(&n, comm[p], 1, 0x20000000u | cob[p], 4) == RRR_CO_ABORT_VALUE);
        CHECK(sdo_write(&n, comm[p], 1, 0xA0000000u | cob[p], 4) == RRR_CO_ABORT_VALUE);
        CHECK(sdo_write(&n, comm[p], 1, 0x00000800u | cob[p], 4) == RRR_CO_ABORT_VALUE);
        CHECK(sdo_write(&n, comm[p], 1, 0x80100000u | cob[p], 4) == RRR_CO_ABORT_VALUE);
        uint32_t v = 0;
        CHECK(sdo_read(&n, comm[p], 1, &v) == 0 && v == cob[p]);
    }
    /* the identifiers of the acceptance, on TPDO1 */
    static const uint32_t bad[] = {0x000u, 0x080u, 0x081u, 0x581u, 0x601u, 0x701u, 0x7E5u};
    rrr_co_node n = booted();
    CHECK(sdo_write(&n, 0x1800, 1, 0x80000000u | (0x180u + ID), 4) == 0);
    for (unsigned i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        CHECK(sdo_write(&n, 0x1800, 1, bad[i], 4) == RRR_CO_ABORT_VALUE);
    }
    /* a restricted identifier while invalid is harmless: nothing is sent on it */
    CHECK(sdo_write(&n, 0x1800, 1, 0x80000000u, 4) == 0); /* invalid, on 0x000 */
    nmt(&n, 0x01, 0);
    sync(&n);
    CHECK(find_out(0x000) == NULL && find_out(0x282) != NULL);
    /* the SYNC and EMCY identifiers are read-only */
    CHECK(sdo_write(&n, 0x1005, 0, 0x181u, 4) == RRR_CO_ABORT_READ_ONLY);
    CHECK(sdo_write(&n, 0x1014, 0, 0x181u, 4) == RRR_CO_ABORT_READ_ONLY);
}

/* What field masters read (ros2_canopen's CiA 402 driver): the mode display 0x6061 in TPDO1, the
 * homing method 0x6098 = 0 (nothing else), the option codes 0x605A..0x605E within what the drive
 * does, and the halt bit: 0 torque in OPERATION ENABLED while it is set, the state kept. */
static void test_field_master_objects(void)
{
    rrr_co_node n = booted();
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x1A00, 0, &v) == 0 && v == 3);
    CHECK(sdo_read(&n, 0x1A00, 3, &v) == 0 && v == 0x60610008u);
    CHECK(sdo_read(&n, 0x6098, 0, &v) == 0 && v == 0);
    CHECK(sdo_write(&n, 0x6098, 0, 35, 1) == RRR_CO_ABORT_TOO_HIGH); /* on current position */
    CHECK(sdo_write(&n, 0x6098, 0, 0xFF, 1) == RRR_CO_ABORT_TOO_LOW); /* -1 */
    CHECK(sdo_write(&n, 0x6098, 0, 0, 1) == 0);
    static const struct {
        uint16_t index;
        int16_t def, lo, hi;
    } codes[] = {{0x605B, 0, 0, 1}, {0x605C, 1, 0, 1}, {0x605D, 1, 1, 2}, {0x605E, 0, 0, 2}};
    for (unsigned i = 0; i < sizeof codes / sizeof codes[0]; ++i) {
        CHECK(sdo_read(&n, codes[i].index, 0, &v) == 0 && (int16_t)v == codes[i].def);
        CHECK(sdo_write(&n, codes[i].index, 0, (uint16_t)(codes[i].hi + 1), 2) ==
              RRR_CO_ABORT_TOO_HIGH);
        CHECK(sdo_write(&n, codes[i].index, 0, (uint16_t)(codes[i].lo - 1), 2) ==
              RRR_CO_ABORT_TOO_LOW);
        CHECK(sdo_write(&n, codes[i].index, 0, (uint16_t)codes[i].lo, 2) == 0);
        CHECK(sdo_write(&n, codes[i].index, 0, (uint16_t)codes[i].hi, 2) == 0);
    }
    CHECK(sdo_read(&n, 0x1200, 1, &v) == 0 && v == 0x600u + ID);
    CHECK(sdo_read(&n, 0x1200, 2, &v) == 0 && v == 0x580u + ID);
    CHECK(sdo_write(&n, 0x1200, 1, 0x601u, 4) == RRR_CO_ABORT_READ_ONLY);
    /* halt: 0 torque while bit 8 is set, OPERATION ENABLED kept, 0x6077 says 0 */
    rrr_co_node m = enabled();
    CHECK(sdo_write(&m, 0x2001, 0, 0, 1) == 0);
    rpdo(&m, 0x010F, 400);
    sync(&m);
    CHECK(m.s402 == RRR_CO_402_OPERATION_ENABLED && rrr_co_torque_Nm(&m) == 0.0);
    const rrr_hil_frame *t2 = find_out(0x282);
    CHECK(t2 && (int16_t)le(t2->data + 4, 2) == 0);
    rpdo(&m, 0x000F, 400);
    sync(&m);
    CHECK_CLOSE(rrr_co_torque_Nm(&m), 400 * (RATED * 1e-6), 1e-9);
    t2 = find_out(0x282);
    CHECK(t2 && (int16_t)le(t2->data + 4, 2) == 400);
    CHECK(m.latch.fault_events == 0 && m.latch.zero_periods == 0);
}

/* Random frames on the node's identifiers: never a crash, at most RRR_CO_MAX_OUT frames out,
 * the statusword always that of the state. */
static void test_hostile(void)
{
    rrr_co_node n = booted();
    rrr_rng rng = {0x9E3779B97F4A7C15ull};
    const uint32_t ids[] = {0x000, 0x080, 0x202, 0x602, 0x701, 0x702, 0x182, 0x7FF};
    unsigned sent = 0;
    for (int k = 0; k < 200000; ++k) {
        rrr_hil_frame f;
        memset(&f, 0, sizeof f);
        f.id = ids[(unsigned)rrr_rng_uniform(&rng, 0, 8) & 7u];
        f.dlc = (uint8_t)rrr_rng_uniform(&rng, 0, 9);
        if (f.dlc > 8) {
            f.dlc = 8;
        }
        for (unsigned i = 0; i < f.dlc; ++i) {
            f.data[i] = (uint8_t)rrr_rng_uniform(&rng, 0, 256);
        }
        if (f.id == 0x000 && f.data[0] == 0x81 && k % 7 != 0) {
            continue; /* fewer resets: let states be reached */
        }
        out.n = 0;
        rrr_co_on_frame(&n, &f, &out);
        rrr_co_transmit(&n, &out);
        rrr_co_advance(&n, (uint32_t)rrr_rng_uniform(&rng, 0, 2000), &out);
        CHECK(out.n <= RRR_CO_MAX_OUT);
        CHECK(n.v[RRR_CO_OD_STATUSWORD] == rrr_co_statusword((rrr_co_402)n.s402));
        CHECK(n.v[RRR_CO_OD_MODE] == RRR_CO_MODE_CST);
        sent += out.n;
    }
    CHECK(sent > 0 && n.err.out_overflow == 0);
}

int rrr_hil_canopen_fuzz_one(const uint8_t *data, size_t size);

/* The fuzz target (c_src/hil/fuzz/fuzz_hil_canopen.c: it traps on a broken invariant) with
 * seeded random inputs shaped like a master's traffic: NMT commands, SDO requests on the
 * dictionary's entries, controlwords and torques in RPDOs, SYNCs, heartbeats, time steps. */
static void test_fuzz_smoke(unsigned runs)
{
    rrr_rng rng = {0x2545F4914F6CDD1Dull};
    static const uint8_t sdo_cs[] = {0x40, 0x2F, 0x2B, 0x27, 0x23, 0x22, 0x21, 0x20,
                                     0x60, 0x70, 0x00, 0x10, 0x0B, 0x80, 0xA0};
    static const uint8_t nmt_cs[] = {0x01, 0x02, 0x80, 0x81, 0x82, 0x01, 0x01};
    static const uint16_t cws[] = {0x06, 0x07, 0x0F, 0x02, 0x00, 0x80, 0x0F, 0x80};
    uint8_t buf[1 + 12 * 48];
    unsigned reached[4] = {0};
    for (unsigned k = 0; k < runs; ++k) {
        const unsigned records = 1u + (unsigned)rrr_rng_uniform(&rng, 0, 48);
        buf[0] = (uint8_t)rrr_rng_uniform(&rng, 0, 256);
        for (unsigned i = 0; i < records; ++i) {
            uint8_t *r = buf + 1 + 12 * i;
            for (unsigned b = 0; b < 12; ++b) {
                r[b] = (uint8_t)rrr_rng_uniform(&rng, 0, 256);
            }
            if (rrr_rng_uniform(&rng, 0, 1) < 0.2) {
                continue; /* raw bytes */
            }
            r[0] &= 0x87u;
            if ((r[0] & 6u) == 4u && (r[1] & 1u)) {
                r[0] = (uint8_t)((r[0] & 0x80u) | 1u); /* half of heartbeats and EMCYs: SYNCs */
            }
            r[2] = 8;
            switch (r[0] & 7u) {
            case 0:
                r[2] = 2;
                r[3] = nmt_cs[(unsigned)rrr_rng_uniform(&rng, 0, sizeof nmt_cs)];
                r[4] = rrr_rng_uniform(&rng, 0, 1) < 0.5 ? 0 : (uint8_t)(buf[0] % 127u + 1u);
                break;
            case 1:
                r[2] = 0;
                break;
            case 2: {
                const rrr_co_od_entry *e =
                    &rrr_co_od[(unsigned)rrr_rng_uniform(&rng, 0, RRR_CO_OD_COUNT)];
                r[3] = sdo_cs[(unsigned)rrr_rng_uniform(&rng, 0, sizeof sdo_cs)];
                r[4] = (uint8_t)e->index;
                r[5] = (uint8_t)(e->index >> 8);
                r[6] = e->subindex;
                break;
            }
            case 3: {
                const uint16_t cw = cws[(unsigned)rrr_rng_uniform(&rng, 0, 8)];
                const int16_t t = (int16_t)rrr_rng_uniform(&rng, -1100, 1100);
                r[2] = 4;
                r[3] = (uint8_t)cw;
                r[4] = (uint8_t)(cw >> 8);
                r[5] = (uint8_t)(uint16_t)t;
                r[6] = (uint8_t)((uint16_t)t >> 8);
                break;
            }
            default:
                r[2] = 1;
                r[3] = 0x05;
                break;
            }
        }
        if (records >= 8u && rrr_rng_uniform(&rng, 0, 1) < 0.5) {
            /* half of the longer inputs start as a master does: NMT start, then shutdown,
             * switch on, enable operation by RPDO, each followed by a SYNC */
            /* op, id low, dlc, data... */
            static const uint8_t script[7][4] = {{0, 0, 2, 0x01}, {3, 0, 4, 0x06}, {1, 0, 0, 0},
                                                 {3, 0, 4, 0x07}, {1, 0, 0, 0},    {3, 0, 4, 0x0F},
                                                 {1, 0, 0, 0}};
            for (unsigned i = 0; i < 7u; ++i) {
                uint8_t *r = buf + 1 + 12 * i;
                memset(r, 0, 12);
                memcpy(r, script[i], 4);
                if (script[i][0] == 3) {
                    r[5] = (uint8_t)rrr_rng_uniform(&rng, 1, 200); /* a target torque */
                }
            }
        }
        const int got = rrr_hil_canopen_fuzz_one(buf, 1 + 12 * records);
        for (unsigned b = 0; b < 4; ++b) {
            reached[b] += (unsigned)(got >> b) & 1u;
        }
    }
    /* a broken invariant traps the process; the inputs reach the deep states */
    printf("fuzz smoke: %u runs: torque applied in %u, FAULT in %u, fault reset in %u, "
           "segmented transfer in %u\n", runs, reached[0], reached[1], reached[2], reached[3]);
    for (unsigned b = 0; b < 4; ++b) {
        CHECK(reached[b] > runs / 100u);
    }
}

/* The quick stop option code 0x605A: 5 and 6 (the default) stay in QUICK STOP ACTIVE, 0, 1
 * and 2 end in SWITCH ON DISABLED at once (0 torque: the ramp is immediate), the others are
 * refused with 0x06090030; never a fault, 0 torque through the latch's output stage. */
static void test_quick_stop_option(void)
{
    rrr_co_node n = enabled();
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x605A, 0, &v) == 0 && v == 6u);
    static const int16_t refused[] = {3, 4, 7, 8, -1, -32768, 32767};
    for (unsigned i = 0; i < sizeof refused / sizeof refused[0]; ++i) {
        CHECK(sdo_write(&n, 0x605A, 0, (uint16_t)refused[i], 2) == RRR_CO_ABORT_VALUE);
    }
    CHECK(sdo_write(&n, 0x605A, 0, 6, 1) == RRR_CO_ABORT_LEN_LOW); /* INTEGER16 */
    CHECK(sdo_read(&n, 0x605A, 0, &v) == 0 && v == 6u && n.s402 == RRR_CO_402_OPERATION_ENABLED);
    static const uint16_t stays[] = {5, 6}, leaves[] = {0, 1, 2};
    for (unsigned i = 0; i < 2; ++i) {
        n = enabled();
        CHECK(sdo_write(&n, 0x605A, 0, stays[i], 2) == 0);
        rpdo(&n, 0x0F, 400);
        sync(&n);
        CHECK_CLOSE(rrr_co_torque_Nm(&n), 400 * (RATED * 1e-6), 1e-9);
        const uint32_t zero0 = n.latch.zero_periods;
        rpdo(&n, 0x02, 400);
        sync(&n);
        CHECK(n.s402 == RRR_CO_402_QUICK_STOP && rrr_co_torque_Nm(&n) == 0.0);
        CHECK(find_out(0x80u + ID) == NULL); /* not a fault: no EMCY */
        const rrr_hil_frame *t1 = find_out(0x182);
        CHECK(t1 && (le(t1->data, 2) & 0x6Fu) == 0x07u);
        rpdo(&n, 0x02, 400);
        sync(&n); /* held, counted by the output stage */
        CHECK(n.latch.zero_periods == zero0 + 2u && n.latch.zero && !n.latch.latched);
        rpdo(&n, 0x0F, 400); /* 16: enable operation leaves it */
        sync(&n);
        CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED && !n.latch.zero);
        CHECK_CLOSE(rrr_co_torque_Nm(&n), 400 * (RATED * 1e-6), 1e-9);
        CHECK(n.latch.fault_events == 0 && n.latch.zero_periods == zero0 + 2u);
    }
    for (unsigned i = 0; i < 3; ++i) {
        n = enabled();
        CHECK(sdo_write(&n, 0x605A, 0, leaves[i], 2) == 0);
        rpdo(&n, 0x0F, -300);
        sync(&n);
        CHECK(rrr_co_torque_Nm(&n) != 0.0);
        rpdo(&n, 0x02, -300);
        sync(&n); /* 11 and 12 at once */
        CHECK(n.s402 == RRR_CO_402_SWITCH_ON_DISABLED && rrr_co_torque_Nm(&n) == 0.0);
        const rrr_hil_frame *t1 = find_out(0x182);
        CHECK(t1 && (le(t1->data, 2) & 0x4Fu) == 0x40u && find_out(0x80u + ID) == NULL);
        rpdo(&n, 0x0F, -300); /* not back by enable operation: the 402 sequence again */
        sync(&n);
        CHECK(n.s402 == RRR_CO_402_SWITCH_ON_DISABLED && rrr_co_torque_Nm(&n) == 0.0);
        for (unsigned k = 0; k < 3; ++k) {
            const uint16_t cw[3] = {0x06, 0x07, 0x0F};
            rpdo(&n, cw[k], -300);
            sync(&n);
        }
        CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED && n.latch.fault_events == 0);
        CHECK_CLOSE(rrr_co_torque_Nm(&n), -300 * (RATED * 1e-6), 1e-9);
    }
    /* the option changed to 0..2 during a quick stop: the stop is complete, SWITCH ON DISABLED */
    n = enabled();
    CHECK(sdo_write(&n, 0x6040, 0, 0x02, 2) == 0 && n.s402 == RRR_CO_402_QUICK_STOP);
    CHECK(sdo_write(&n, 0x605A, 0, 5, 2) == 0 && n.s402 == RRR_CO_402_QUICK_STOP);
    CHECK(sdo_write(&n, 0x605A, 0, 2, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    /* quick stop from READY TO SWITCH ON / SWITCHED ON is SWITCH ON DISABLED with any code */
    CHECK(sdo_write(&n, 0x605A, 0, 6, 2) == 0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x06, 2) == 0 && sdo_write(&n, 0x6040, 0, 0x07, 2) == 0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x02, 2) == 0 && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    /* reset communication keeps it (0x6000 range), reset node restores the default */
    CHECK(sdo_write(&n, 0x605A, 0, 0, 2) == 0);
    nmt(&n, 0x82, 0);
    CHECK(sdo_read(&n, 0x605A, 0, &v) == 0 && v == 0u);
    nmt(&n, 0x81, 0);
    CHECK(sdo_read(&n, 0x605A, 0, &v) == 0 && v == 6u);
}

/* The max torque 0x6072 (per mille of 0x6076) is the target torque's limit: an SDO write
 * beyond it is refused, an RPDO beyond it is a fault (EMCY 0x6320, FAULT, 0 torque, latched
 * until the 402 fault reset); the default 1000 is the rated torque. */
static void test_max_torque(void)
{
    rrr_co_node n = enabled();
    uint32_t v = 0;
    CHECK(sdo_read(&n, 0x6072, 0, &v) == 0 && v == 1000u);
    CHECK(sdo_write(&n, 0x6072, 0, 500, 2) == 0);
    CHECK(sdo_write(&n, 0x6071, 0, 501, 2) == RRR_CO_ABORT_TOO_HIGH);
    CHECK(sdo_write(&n, 0x6071, 0, (uint16_t)-501, 2) == RRR_CO_ABORT_TOO_LOW);
    CHECK(sdo_write(&n, 0x6071, 0, (uint16_t)-500, 2) == 0);
    CHECK_CLOSE(rrr_co_torque_Nm(&n), -500 * (RATED * 1e-6), 1e-9);
    /* not below the target torque in force */
    CHECK(sdo_write(&n, 0x6072, 0, 499, 2) == RRR_CO_ABORT_TOO_LOW);
    CHECK(sdo_read(&n, 0x6072, 0, &v) == 0 && v == 500u);
    rpdo(&n, 0x0F, 500);
    sync(&n);
    CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED && n.latch.fault_events == 0);
    const uint32_t zero0 = n.latch.zero_periods;
    rpdo(&n, 0x0F, 501); /* beyond 0x6072, within the rated torque */
    sync(&n);
    CHECK(has_emcy(RRR_CO_EMCY_PARAM, 0x21) && n.s402 == RRR_CO_402_FAULT);
    CHECK(n.latch.latched && n.latch.code == RRR_CO_EMCY_PARAM && n.latch.fault_events == 1);
    CHECK(rrr_co_torque_Nm(&n) == 0.0 && n.v[RRR_CO_OD_TARGET_TORQUE] == 500u); /* not applied */
    const rrr_hil_frame *t1 = find_out(0x182);
    CHECK(t1 && (le(t1->data, 2) & 0x4Fu) == 0x08u);
    for (int k = 0; k < 3; ++k) { /* enable operation does not clear it */
        rpdo(&n, 0x0F, 100);
        sync(&n);
        CHECK(n.s402 == RRR_CO_402_FAULT && rrr_co_torque_Nm(&n) == 0.0);
    }
    CHECK(n.latch.zero_periods == zero0 + 4u && n.latch.resets == 0);
    CHECK(sdo_read(&n, 0x603F, 0, &v) == 0 && v == RRR_CO_EMCY_PARAM);
    /* the 402 fault reset, then the enabling sequence */
    const uint16_t seq[4] = {0x80, 0x06, 0x07, 0x0F};
    for (unsigned k = 0; k < 4; ++k) {
        rpdo(&n, seq[k], 100);
        sync(&n);
        if (k == 0) {
            CHECK(has_emcy(RRR_CO_EMCY_RESET, 0x00) && n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
        }
    }
    CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED && !n.latch.latched && n.latch.resets == 1);
    CHECK_CLOSE(rrr_co_torque_Nm(&n), 100 * (RATED * 1e-6), 1e-9);
    /* above the rated torque (an overload range): 1500 per mille is applied, 1501 is not */
    CHECK(sdo_write(&n, 0x6072, 0, 1500, 2) == 0);
    rpdo(&n, 0x0F, 1500);
    sync(&n);
    CHECK(n.s402 == RRR_CO_402_OPERATION_ENABLED);
    CHECK_CLOSE(rrr_co_torque_Nm(&n), 1500 * (RATED * 1e-6), 1e-9);
    t1 = find_out(0x282);
    CHECK(t1 && (int16_t)le(t1->data + 4, 2) == 1500); /* the torque actual value */
    rpdo(&n, 0x0F, -1501);
    sync(&n);
    CHECK(has_emcy(RRR_CO_EMCY_PARAM, 0x21) && n.s402 == RRR_CO_402_FAULT);
    CHECK(n.latch.fault_events == 2);
    /* 0: only a zero target; 65535: every INTEGER16 */
    n = enabled();
    CHECK(sdo_write(&n, 0x6072, 0, 0, 2) == 0);
    CHECK(sdo_write(&n, 0x6071, 0, 1, 2) == RRR_CO_ABORT_TOO_HIGH);
    CHECK(sdo_write(&n, 0x6072, 0, 65535, 2) == 0);
    CHECK(sdo_write(&n, 0x6071, 0, (uint16_t)INT16_MIN, 2) == 0);
    CHECK(sdo_write(&n, 0x6072, 0, 32767, 2) == RRR_CO_ABORT_TOO_LOW); /* |-32768| > 32767 */
    CHECK(sdo_write(&n, 0x6072, 0, 1000, 4) == RRR_CO_ABORT_LEN_HIGH); /* UNSIGNED16 */
    /* reset node restores the default */
    nmt(&n, 0x81, 0);
    CHECK(sdo_read(&n, 0x6072, 0, &v) == 0 && v == 1000u);
    CHECK(sdo_read(&n, 0x6071, 0, &v) == 0 && v == 0u);
}

/* The latch is the drive's safety policy: latched exactly in FAULT with the EMCY code, reset by
 * the 402 fault reset's rising edge only (and by a reset node, the application's restart). */
static void test_latch_is_the_policy(void)
{
    rrr_co_node n = enabled();
    CHECK(!n.latch.latched && n.latch.fault_events == 0 && n.latch.resets == 0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x80, 2) == 0); /* a rising edge with nothing latched */
    CHECK(n.latch.resets == 0 && n.s402 == RRR_CO_402_OPERATION_ENABLED);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0);
    rrr_co_raise_fault(&n, 0x8140, RRR_CO_ERR_COMM, &out);
    CHECK(n.latch.latched && n.latch.code == 0x8140u && n.s402 == RRR_CO_402_FAULT);
    CHECK(rrr_co_torque_Nm(&n) == 0.0 && has_emcy(0x8140, 0x11));
    nmt(&n, 0x82, 0); /* reset communication does not clear it */
    CHECK(n.latch.latched && n.s402 == RRR_CO_402_FAULT && n.v[RRR_CO_OD_ERROR_REGISTER] == 0x11u);
    nmt(&n, 0x01, 0);
    CHECK(sdo_write(&n, 0x6040, 0, 0x0F, 2) == 0 && n.latch.latched);
    CHECK(sdo_write(&n, 0x6040, 0, 0x8F, 2) == 0 && !n.latch.latched && n.latch.resets == 1);
    CHECK(n.s402 == RRR_CO_402_SWITCH_ON_DISABLED);
    rrr_co_raise_fault(&n, 0x5530, RRR_CO_ERR_MANUFACTURER, &out);
    nmt(&n, 0x81, 0); /* reset node: the drive restarts, every value at its default */
    CHECK(!n.latch.latched && n.latch.resets == 2 && n.latch.fault_events == 2);
    CHECK(n.s402 == RRR_CO_402_SWITCH_ON_DISABLED && n.v[RRR_CO_OD_ERROR_REGISTER] == 0u);
}

int main(void)
{
    test_quick_stop_option();
    test_max_torque();
    test_latch_is_the_policy();
    test_boot_and_nmt();
    test_sdo();
    test_segmented_upload();
    test_sdo_timeout();
    test_402();
    test_pdo_on_sync();
    test_rpdo_timeout();
    test_heartbeat();
    test_mapping_by_sdo();
    test_cob_id_rules();
    test_field_master_objects();
    test_hostile();
    test_fuzz_smoke(20000);
    return rrr_test_report("test_hil_canopen");
}
