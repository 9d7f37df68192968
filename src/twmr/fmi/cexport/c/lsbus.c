/* FMI-LS-BUS CAN operations in C: see lsbus.h. */
#include <string.h>
#include "lsbus.h"

static void put32(unsigned char *p, unsigned long v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}

static unsigned long get32(const unsigned char *p) {
    return p[0] | (unsigned long)p[1] << 8 | (unsigned long)p[2] << 16 | (unsigned long)p[3] << 24;
}

void lsbus_transmit(LsbusBuffer *buf, const CanFrame *f) {
    size_t data = f->rtr ? 0 : f->length, total = LSBUS_HEADER + 8 + data;
    unsigned char *p = buf->b + buf->n;
    if (buf->n + total > sizeof buf->b) {
        buf->overflow++;
        return;
    }
    put32(p, LSBUS_CAN_TRANSMIT);
    put32(p + 4, total);
    put32(p + 8, f->id);
    p[12] = (unsigned char)(f->ide != 0);
    p[13] = (unsigned char)(f->rtr != 0);
    p[14] = (unsigned char)f->length;
    p[15] = (unsigned char)(f->length >> 8);
    if (data) memcpy(p + 16, f->data, data);
    buf->n += total;
}

long lsbus_next(const unsigned char *bytes, size_t size, size_t at, unsigned *code, CanFrame *f) {
    unsigned long len;
    const unsigned char *p = bytes + at;
    if (at >= size) return 0;
    if (size - at < LSBUS_HEADER) return -1;
    *code = (unsigned)get32(p);
    len = get32(p + 4);
    if (len < LSBUS_HEADER || len > size - at) return -1;
    if (*code == LSBUS_CAN_TRANSMIT) {
        if (len < LSBUS_HEADER + 8) return -1;
        f->id = get32(p + 8);
        f->ide = p[12] != 0;
        f->rtr = p[13] != 0;
        f->length = p[14] | (unsigned)p[15] << 8;
        f->data = p + 16;
        if (len != LSBUS_HEADER + 8 + (f->rtr ? 0 : f->length)) return -1;
    } else {
        f->data = p + LSBUS_HEADER;
        f->length = (unsigned)(len - LSBUS_HEADER);
    }
    return (long)(at + len);
}
