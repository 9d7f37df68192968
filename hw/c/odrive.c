/* ODrive "CAN Simple" frames in C: see odrive.h. */
#include <string.h>
#include "odrive.h"

#define TWO_PI (2.0 * 3.141592653589793)

static void put32(unsigned char *p, unsigned long v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}

static unsigned long get32(const unsigned char *p) {
    return p[0] | (unsigned long)p[1] << 8 | (unsigned long)p[2] << 16 | (unsigned long)p[3] << 24;
}

static void put_f32(unsigned char *p, double x) {
    float f = (float)x;
    unsigned int bits;
    memcpy(&bits, &f, 4);
    put32(p, bits);
}

static double get_f32(const unsigned char *p) {
    unsigned int bits = (unsigned int)get32(p);
    float f;
    memcpy(&f, &bits, 4);
    return (double)f;
}

unsigned odrive_can_id(unsigned node, unsigned cmd) { return node << 5 | cmd; }

void odrive_split_id(unsigned long id, unsigned *node, unsigned *cmd) {
    *node = (unsigned)(id >> 5);
    *cmd = (unsigned)(id & 0x1F);
}

unsigned odrive_encode_torque(double wheel_torque, double gear, unsigned char data[8]) {
    put_f32(data, wheel_torque / gear);
    put32(data + 4, 0);
    return 8;
}

double odrive_decode_torque(const unsigned char data[8], double gear) {
    return get_f32(data) * gear;
}

unsigned odrive_encode_axis_state(unsigned state, unsigned char data[8]) {
    put32(data, state);
    put32(data + 4, 0);
    return 8;
}

unsigned odrive_encode_controller_mode(unsigned control, unsigned input_mode,
                                       unsigned char data[8]) {
    put32(data, control);
    put32(data + 4, input_mode);
    return 8;
}

unsigned odrive_encode_limits(double wheel_speed_limit, double current_limit, double gear,
                              unsigned char data[8]) {
    put_f32(data, wheel_speed_limit * gear / TWO_PI);
    put_f32(data + 4, current_limit);
    return 8;
}

unsigned odrive_encode_clear_errors(int line, unsigned char data[8]) {
    if (line == 5) return 0;
    data[0] = 0;
    return 1;
}

void odrive_decode_encoder(const unsigned char data[8], double gear, double *wheel_angle,
                           double *wheel_speed) {
    *wheel_angle = get_f32(data) * TWO_PI / gear;
    *wheel_speed = get_f32(data + 4) * TWO_PI / gear;
}
