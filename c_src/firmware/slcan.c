/* SLCAN from the adapter's side (slcan.h). */
#include "slcan.h"

#include <string.h>

static const char HEX[] = "0123456789ABCDEF";

void pil_slcan_init(pil_slcan *s)
{
    memset(s, 0, sizeof *s);
    s->bitrate = -1;
}

int pil_slcan_can_send(const pil_slcan *s)
{
    return s->open == 1;
}

static int hex_digit(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

/* n hex digits of p as a number: 0, or -1 for a character that is not one */
static int hex_value(const char *p, unsigned n, uint32_t *v)
{
    uint32_t x = 0u;
    for (unsigned i = 0; i < n; ++i) {
        const int d = hex_digit(p[i]);
        if (d < 0) {
            return -1;
        }
        x = (x << 4) | (uint32_t)d;
    }
    *v = x;
    return 0;
}

/* A `t` (ids = 3) or `T` (ids = 8) line into f: 0, or -1 when it is not a valid frame. */
static int parse_frame(const char *line, unsigned len, unsigned ids, rrr_hil_frame *f)
{
    uint32_t id, dlc;
    if (len < 1u + ids + 1u || hex_value(line + 1, ids, &id) != 0 ||
        hex_value(line + 1 + ids, 1u, &dlc) != 0 || dlc > 8u || len != 2u + ids + 2u * dlc) {
        return -1;
    }
    if ((ids == 3u && id > 0x7FFu) || (ids == 8u && id > 0x1FFFFFFFu)) {
        return -1;
    }
    rrr_hil_frame g;
    memset(&g, 0, sizeof g);
    g.id = id;
    g.extended = (uint8_t)(ids == 8u);
    g.dlc = (uint8_t)dlc;
    for (uint32_t i = 0; i < dlc; ++i) {
        uint32_t b;
        if (hex_value(line + 2u + ids + 2u * i, 2u, &b) != 0) {
            return -1;
        }
        g.data[i] = (uint8_t)b;
    }
    *f = g;
    return 0;
}

static size_t put(char *reply, const char *text)
{
    const size_t n = strlen(text);
    memcpy(reply, text, n);
    return n;
}

/* The reply and event of one complete line. */
static pil_slcan_event line_done(pil_slcan *s, rrr_hil_frame *f, char *reply, size_t *reply_len)
{
    const char *l = s->line;
    const unsigned n = s->len;
    pil_slcan_event ev = PIL_SLCAN_NONE;
    const char *ok = "\r";
    int good = 0;
    if (s->overflow) {
        good = 0;
    } else if (n == 0u) {
        good = 1; /* python-can writes an empty command for "no data bit rate" */
    } else if ((l[0] == 't' || l[0] == 'T') && s->open == 1) {
        good = parse_frame(l, n, l[0] == 't' ? 3u : 8u, f) == 0;
        if (good) {
            ok = l[0] == 't' ? "z\r" : "Z\r";
            ev = PIL_SLCAN_FRAME;
            ++s->rx_frames;
        }
    } else if (n == 1u && (l[0] == 'O' || l[0] == 'L')) {
        good = s->open == 0;
        if (good) {
            s->open = l[0] == 'O' ? 1 : 2;
            ev = PIL_SLCAN_OPENED;
        }
    } else if (n == 1u && l[0] == 'C') {
        good = 1; /* closing a closed channel is harmless (python-can does it first) */
        if (s->open != 0) {
            s->open = 0;
            ++s->closes;
            ev = PIL_SLCAN_CLOSED;
        }
    } else if (n == 2u && l[0] == 'S' && l[1] >= '0' && l[1] <= '8') {
        good = s->open == 0;
        if (good) {
            s->bitrate = l[1] - '0';
        }
    } else if (n == 5u && l[0] == 's') {
        uint32_t btr;
        good = s->open == 0 && hex_value(l + 1, 4u, &btr) == 0;
    } else if (n == 1u && l[0] == 'V') {
        good = 1;
        ok = "V1013\r";
    } else if (n == 1u && l[0] == 'v') {
        good = 1;
        ok = "v1013\r";
    } else if (n == 1u && l[0] == 'N') {
        good = 1;
        ok = "NRRR1\r";
    } else if (n == 1u && l[0] == 'F') {
        good = 1;
        ok = "F00\r";
    } else if (n == 2u && l[0] == 'Z' && l[1] == '0') {
        good = 1;
    }
    if (good) {
        ++s->commands;
        *reply_len = put(reply, ok);
    } else {
        ++s->refused;
        *reply_len = put(reply, "\a");
        ev = PIL_SLCAN_NONE;
    }
    s->len = 0u;
    s->overflow = 0;
    return ev;
}

pil_slcan_event pil_slcan_feed(pil_slcan *s, char c, rrr_hil_frame *f, char *reply,
                               size_t *reply_len)
{
    *reply_len = 0u;
    if (c == '\r') {
        return line_done(s, f, reply, reply_len);
    }
    if (c == '\n') {
        return PIL_SLCAN_NONE; /* a terminal's CR LF: the LF is ignored */
    }
    if (s->len < PIL_SLCAN_LINE_MAX) {
        s->line[s->len++] = c;
    } else {
        s->overflow = 1;
    }
    return PIL_SLCAN_NONE;
}

size_t pil_slcan_format(const rrr_hil_frame *f, char *out)
{
    if (f->dlc > 8u) {
        return 0u;
    }
    size_t n = 0u;
    const unsigned ids = f->extended ? 8u : 3u;
    out[n++] = f->extended ? 'T' : 't';
    for (unsigned i = 0; i < ids; ++i) {
        out[n++] = HEX[(f->id >> (4u * (ids - 1u - i))) & 0xFu];
    }
    out[n++] = HEX[f->dlc];
    for (unsigned i = 0; i < f->dlc; ++i) {
        out[n++] = HEX[f->data[i] >> 4];
        out[n++] = HEX[f->data[i] & 0xFu];
    }
    out[n++] = '\r';
    return n;
}
