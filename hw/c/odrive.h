/* ODrive "CAN Simple" frames in C: the C twin of twmr.hw.protocol (the same identifiers, layouts,
 * scalings and float32 conversions, in the same order of operations), for a controller FMU on a
 * CAN terminal. Wheel units at the edges (rad, rad/s, N.m); the drive works in motor turns and
 * motor N.m through the gear ratio (motor turns per wheel turn). Every frame is 8 bytes except
 * Clear_Errors (none on firmware 0.5.x, one `Identify` byte on 0.6.x). */
#ifndef TWMR_ODRIVE_H
#define TWMR_ODRIVE_H

enum { ODRIVE_HEARTBEAT = 0x01, ODRIVE_ESTOP = 0x02, ODRIVE_SET_AXIS_STATE = 0x07, ODRIVE_GET_ENCODER_ESTIMATES = 0x09,
       ODRIVE_SET_CONTROLLER_MODE = 0x0B, ODRIVE_SET_INPUT_TORQUE = 0x0E,
       ODRIVE_SET_LIMITS = 0x0F, ODRIVE_CLEAR_ERRORS = 0x18 };
enum { ODRIVE_AXIS_IDLE = 1, ODRIVE_AXIS_CLOSED_LOOP = 8, ODRIVE_CONTROL_TORQUE = 1,
       ODRIVE_INPUT_PASSTHROUGH = 1 };

unsigned odrive_can_id(unsigned node, unsigned cmd);
void odrive_split_id(unsigned long id, unsigned *node, unsigned *cmd);
/* each encoder writes the frame's data and returns its length (bytes) */
unsigned odrive_encode_torque(double wheel_torque, double gear, unsigned char data[8]);
double odrive_decode_torque(const unsigned char data[8], double gear);
unsigned odrive_encode_axis_state(unsigned state, unsigned char data[8]);
unsigned odrive_encode_controller_mode(unsigned control, unsigned input_mode,
                                       unsigned char data[8]);
unsigned odrive_encode_limits(double wheel_speed_limit, double current_limit, double gear,
                              unsigned char data[8]);
unsigned odrive_encode_clear_errors(int line, unsigned char data[8]);  /* line 5 or 6 */
void odrive_decode_encoder(const unsigned char data[8], double gear, double *wheel_angle,
                           double *wheel_speed);

#endif
