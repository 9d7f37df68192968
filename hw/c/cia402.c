/* CiA 402 over CANopen in C: see cia402.h. */
#include <math.h>
#include "cia402.h"

#define PI 3.141592653589793

static const struct { unsigned mask, value; int state; } STATUS[] = {
    {0x4F, 0x00, CIA402_NOT_READY}, {0x4F, 0x40, CIA402_SWITCH_ON_DISABLED},
    {0x6F, 0x21, CIA402_READY}, {0x6F, 0x23, CIA402_SWITCHED_ON},
    {0x6F, 0x27, CIA402_OPERATION_ENABLED}, {0x6F, 0x07, CIA402_QUICK_STOP},
    {0x4F, 0x0F, CIA402_FAULT_REACTION}, {0x4F, 0x08, CIA402_FAULT},
};

int cia402_state(unsigned statusword) {
    unsigned i;
    for (i = 0; i < sizeof STATUS / sizeof STATUS[0]; i++)
        if ((statusword & STATUS[i].mask) == STATUS[i].value) return STATUS[i].state;
    return -1;
}

unsigned cia402_next_controlword(int state) {
    switch (state) {
    case CIA402_FAULT: return CIA402_FAULT_RESET;
    case CIA402_SWITCH_ON_DISABLED: return CIA402_SHUTDOWN;
    case CIA402_READY: return CIA402_SWITCH_ON;
    case CIA402_SWITCHED_ON: return CIA402_ENABLE_OPERATION;
    case CIA402_OPERATION_ENABLED: return CIA402_ENABLE_OPERATION;
    default: return CIA402_DISABLE_VOLTAGE;
    }
}

int cia402_torque_to_permille(double wheel_torque, double gear, long rated_torque_mNm) {
    double value = nearbyint(1000.0 * (wheel_torque / gear) / ((double)rated_torque_mNm / 1000.0));
    return value > 32767.0 ? 32767 : (value < -32768.0 ? -32768 : (int)value);
}

double cia402_permille_to_torque(long permille, double gear, long rated_torque_mNm) {
    return (double)permille / 1000.0 * (double)rated_torque_mNm / 1000.0 * gear;
}

double cia402_velocity_to_si(long value, double gear, double rpm_per_unit) {
    return (double)value * rpm_per_unit * 2.0 * PI / 60.0 / gear;
}

unsigned cia402_encode_rpdo1(unsigned controlword, int permille, unsigned char data[8]) {
    unsigned t = (unsigned)permille & 0xFFFF;
    data[0] = (unsigned char)controlword; data[1] = (unsigned char)(controlword >> 8);
    data[2] = (unsigned char)t; data[3] = (unsigned char)(t >> 8);
    return 4;
}

void cia402_decode_tpdo1(const unsigned char data[8], unsigned *statusword, long *velocity) {
    unsigned long v = data[2] | (unsigned long)data[3] << 8 | (unsigned long)data[4] << 16
                      | (unsigned long)data[5] << 24;
    *statusword = data[0] | (unsigned)data[1] << 8;
    *velocity = v >= 0x80000000UL ? -(long)(0xFFFFFFFFUL - v) - 1 : (long)v;
}
