/* CiA 402 over CANopen in C: the C twin of twmr.hw.cia402 (power state machine, unit
 * conversions) and of the PDO layout twmr.hw.cia402_link maps: RPDO1 0x200 + node = controlword
 * 0x6040 (UNSIGNED16) + target torque 0x6071 (INTEGER16, per mille of the rated torque 0x6076),
 * TPDO1 0x180 + node = statusword 0x6041 (UNSIGNED16) + velocity actual 0x606C (INTEGER32, motor
 * rpm), both little-endian; SYNC 0x080 without data; NMT start 0x000 [0x01, node]. */
#ifndef TWMR_CIA402_H
#define TWMR_CIA402_H

/* the power states, in the order of twmr.hw.cia402.State */
enum { CIA402_NOT_READY, CIA402_SWITCH_ON_DISABLED, CIA402_READY, CIA402_SWITCHED_ON,
       CIA402_OPERATION_ENABLED, CIA402_QUICK_STOP, CIA402_FAULT_REACTION, CIA402_FAULT };
enum { CIA402_SHUTDOWN = 0x06, CIA402_SWITCH_ON = 0x07, CIA402_ENABLE_OPERATION = 0x0F,
       CIA402_DISABLE_VOLTAGE = 0x00, CIA402_FAULT_RESET = 0x80 };
enum { CIA402_RPDO1 = 0x200, CIA402_TPDO1 = 0x180, CIA402_SYNC = 0x080, CIA402_NMT = 0x000,
       CIA402_NMT_START = 0x01 };

/* the state a statusword reports, -1 when it matches none */
int cia402_state(unsigned statusword);
unsigned cia402_next_controlword(int state);
int cia402_torque_to_permille(double wheel_torque, double gear, long rated_torque_mNm);
double cia402_permille_to_torque(long permille, double gear, long rated_torque_mNm);
double cia402_velocity_to_si(long value, double gear, double rpm_per_unit);
unsigned cia402_encode_rpdo1(unsigned controlword, int permille, unsigned char data[8]);
void cia402_decode_tpdo1(const unsigned char data[8], unsigned *statusword, long *velocity);

#endif
