/* The firmware's SLCAN adapter (c_src/firmware/slcan.h): the commands python-can's slcan
 * interface sends, frames both ways, what is refused, and random input. */
#include <stdlib.h>
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"
#include "slcan.h"

typedef struct fed {
    pil_slcan_event ev;
    rrr_hil_frame f;
    char reply[PIL_SLCAN_REPLY_MAX + 1];
} fed;

/* Feed a whole line (with its CR): the event and reply of the CR. */
static fed feed_line(pil_slcan *s, const char *line)
{
    fed out;
    memset(&out, 0, sizeof out);
    for (const char *p = line; *p != '\0'; ++p) {
        size_t n = 0;
        out.ev = pil_slcan_feed(s, *p, &out.f, out.reply, &n);
        out.reply[n] = '\0';
    }
    return out;
}

static void test_python_can_open(void)
{
    pil_slcan s;
    pil_slcan_init(&s);
    CHECK(!pil_slcan_can_send(&s));
    /* python-can's slcanBus(bitrate=1000000): close, S8, the empty data bit rate, open, open */
    CHECK(strcmp(feed_line(&s, "C\r").reply, "\r") == 0);
    CHECK(strcmp(feed_line(&s, "S8\r").reply, "\r") == 0);
    CHECK(s.bitrate == 8);
    CHECK(strcmp(feed_line(&s, "\r").reply, "\r") == 0);
    const fed o = feed_line(&s, "O\r");
    CHECK(o.ev == PIL_SLCAN_OPENED && strcmp(o.reply, "\r") == 0);
    CHECK(pil_slcan_can_send(&s));
    CHECK(strcmp(feed_line(&s, "O\r").reply, "\a") == 0); /* already open */
    CHECK(strcmp(feed_line(&s, "S6\r").reply, "\a") == 0); /* no bit rate while open */
    CHECK(s.bitrate == 8);
    CHECK(strcmp(feed_line(&s, "V\r").reply, "V1013\r") == 0);
    CHECK(strcmp(feed_line(&s, "F\r").reply, "F00\r") == 0);
    const fed c = feed_line(&s, "C\r");
    CHECK(c.ev == PIL_SLCAN_CLOSED && strcmp(c.reply, "\r") == 0 && s.closes == 1u);
    CHECK(!pil_slcan_can_send(&s));
    CHECK(s.refused == 2u);
}

static void test_frames(void)
{
    pil_slcan s;
    pil_slcan_init(&s);
    CHECK(strcmp(feed_line(&s, "t1002AABB\r").reply, "\a") == 0); /* closed: refused */
    (void)feed_line(&s, "O\r");
    fed f = feed_line(&s, "t20188F000000F5ADFAFF\r");
    CHECK(f.ev == PIL_SLCAN_FRAME && strcmp(f.reply, "z\r") == 0);
    const uint8_t data[8] = {0x8F, 0, 0, 0, 0xF5, 0xAD, 0xFA, 0xFF};
    CHECK(f.f.id == 0x201u && f.f.dlc == 8u && !f.f.extended && memcmp(f.f.data, data, 8) == 0);
    f = feed_line(&s, "t7012050a\r"); /* lower-case hex is accepted */
    CHECK(f.ev == PIL_SLCAN_FRAME && f.f.id == 0x701u && f.f.dlc == 2u && f.f.data[0] == 5u &&
          f.f.data[1] == 0x0Au);
    f = feed_line(&s, "T1ABCDEF00\r");
    CHECK(f.ev == PIL_SLCAN_FRAME && f.f.extended && f.f.id == 0x1ABCDEF0u && f.f.dlc == 0u &&
          strcmp(f.reply, "Z\r") == 0);
    const char *bad[] = {"t10\r", "t1009\r", "t1001\r", "t1001GG\r", "t800\r", "T2000000000\r",
                         "t10010000\r", "r1000\r", "d1001AA\r", "b1001AA\r", "X\r",
                         "t100800000000000000000000000000\r"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        const fed b = feed_line(&s, bad[i]);
        CHECK(b.ev == PIL_SLCAN_NONE && strcmp(b.reply, "\a") == 0);
    }
    CHECK(s.rx_frames == 3u);
    /* after an overlong line the next is parsed afresh */
    CHECK(feed_line(&s, "t0804000000FF\r").ev == PIL_SLCAN_FRAME);
    /* listen-only: open, but the node may not send and no frame is taken */
    pil_slcan l;
    pil_slcan_init(&l);
    CHECK(feed_line(&l, "L\r").ev == PIL_SLCAN_OPENED && !pil_slcan_can_send(&l));
    CHECK(feed_line(&l, "t0800\r").ev == PIL_SLCAN_NONE);
}

static void test_format_round_trip(void)
{
    rrr_rng rng = {0x5eed1234u};
    pil_slcan s;
    pil_slcan_init(&s);
    (void)feed_line(&s, "O\r");
    for (int i = 0; i < 20000; ++i) {
        rrr_hil_frame f;
        memset(&f, 0, sizeof f);
        f.extended = (uint8_t)(rrr_rng_uniform(&rng, 0.0, 1.0) < 0.3);
        f.id = (uint32_t)rrr_rng_uniform(&rng, 0.0, f.extended ? 536870911.0 : 2047.0);
        f.dlc = (uint8_t)rrr_rng_uniform(&rng, 0.0, 8.999);
        for (unsigned k = 0; k < f.dlc; ++k) {
            f.data[k] = (uint8_t)rrr_rng_uniform(&rng, 0.0, 255.999);
        }
        char line[PIL_SLCAN_LINE_MAX + 2];
        const size_t n = pil_slcan_format(&f, line);
        CHECK(n >= 6u && n <= PIL_SLCAN_LINE_MAX + 1u && line[n - 1] == '\r');
        line[n] = '\0';
        const fed back = feed_line(&s, line);
        CHECK(back.ev == PIL_SLCAN_FRAME && memcmp(&back.f, &f, sizeof f) == 0);
    }
    rrr_hil_frame too_long;
    memset(&too_long, 0, sizeof too_long);
    too_long.dlc = 9;
    char line[PIL_SLCAN_LINE_MAX + 2];
    CHECK(pil_slcan_format(&too_long, line) == 0u);
}

/* Random bytes: every line gets a reply, the buffer is never overrun (ASan), frames are
 * classical and well formed. */
static void test_random_input(void)
{
    rrr_rng rng = {42u};
    static const char alphabet[] = "tTrRdDbBOLCSsVvNFZ0123456789abcdefABCDEFXYZ\r\r\r\n ";
    pil_slcan s;
    pil_slcan_init(&s);
    unsigned long lines = 0;
    for (int i = 0; i < 400000; ++i) {
        const char c = alphabet[(size_t)rrr_rng_uniform(&rng, 0.0, sizeof alphabet - 1.001)];
        rrr_hil_frame f;
        char reply[PIL_SLCAN_REPLY_MAX];
        size_t n = 0;
        const pil_slcan_event ev = pil_slcan_feed(&s, c, &f, reply, &n);
        CHECK(n <= PIL_SLCAN_REPLY_MAX);
        if (c == '\r') {
            ++lines;
            CHECK(n >= 1u && reply[n - 1] == (n == 1u && reply[0] == '\a' ? '\a' : '\r'));
        } else {
            CHECK(n == 0u && ev == PIL_SLCAN_NONE);
        }
        if (ev == PIL_SLCAN_FRAME) {
            CHECK(f.dlc <= 8u && (f.extended ? f.id <= 0x1FFFFFFFu : f.id <= 0x7FFu));
        }
    }
    CHECK(lines == s.commands + s.refused);
}

int main(void)
{
    test_python_can_open();
    test_frames();
    test_format_round_trip();
    test_random_input();
    return rrr_test_report("test_pil_slcan");
}
