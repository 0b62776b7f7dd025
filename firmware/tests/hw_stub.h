#ifndef HW_STUB_H
#define HW_STUB_H
#include <stddef.h>
#include <stdint.h>

#include "labkit_core.h"

#define STUB_OUT_SIZE 65536
extern char stub_out[STUB_OUT_SIZE];
extern size_t stub_out_len;
extern uint16_t stub_adc[6];
extern uint8_t stub_eeprom[1024];
extern uint16_t stub_pulses[8];
extern unsigned stub_pulse_updates;
extern int stub_ee_fail;
void stub_clear(void);
#endif
