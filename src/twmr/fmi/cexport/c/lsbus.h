/* FMI-LS-BUS CAN operations in C (the C twin of twmr.fmi.lsbus.operations for what a CAN node of
 * ours sends and reads): an 8-byte header, operation code (uint32) and total length (uint32),
 * then the fields, packed, little-endian. CAN Transmit (0x10): id (4), ide (1), rtr (1), data
 * length (2), data (none for a remote frame). Bus Error (0x31): id (4), error code (1), error flag
 * (1), is sender (1). Status (0x41): status (1; 3 is bus-off). */
#ifndef TWMR_LSBUS_H
#define TWMR_LSBUS_H

#include <stddef.h>

enum { LSBUS_CAN_TRANSMIT = 0x10, LSBUS_BUS_ERROR = 0x31, LSBUS_STATUS = 0x41, LSBUS_BUS_OFF = 3,
       LSBUS_HEADER = 8, LSBUS_TX_BYTES = 1024 };

/* the operations a node sends at one tick of its Tx clock */
typedef struct {
    unsigned char b[LSBUS_TX_BYTES];
    size_t n;
    int overflow;  /* operations dropped because the buffer was full */
} LsbusBuffer;

/* one CAN frame read from, or written to, the bus */
typedef struct {
    unsigned long id;
    int ide, rtr;
    unsigned length;  /* data length code: the data's length, or the length a remote frame asks */
    const unsigned char *data;
} CanFrame;

/* Append a CAN Transmit of `f` (f->data unread for a remote frame). */
void lsbus_transmit(LsbusBuffer *buf, const CanFrame *f);

/* The next operation of `bytes` at offset `at`: its code, and the frame when it is a CAN
 * Transmit (any other operation: f->data its fields, f->length their bytes); the offset after it, or 0 at the end; -1 when the bytes are malformed there (a
 * length shorter than the header or running past the end, a transmit whose data does not fit). */
long lsbus_next(const unsigned char *bytes, size_t size, size_t at, unsigned *code, CanFrame *f);

#endif
