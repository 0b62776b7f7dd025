/* Host stand-ins for the lk_hw_* functions: capture output, fake ADC/EEPROM/pulses. */
#include <string.h>

#include "hw_stub.h"

char stub_out[STUB_OUT_SIZE];
size_t stub_out_len;
uint16_t stub_adc[6];
uint8_t stub_eeprom[1024];
uint16_t stub_pulses[8];
unsigned stub_pulse_updates;
int stub_ee_fail;

void stub_clear(void) { stub_out_len = 0; stub_out[0] = 0; }

void lk_hw_write(const char *buf, uint8_t n) {
    if (stub_out_len + n >= STUB_OUT_SIZE) stub_out_len = 0; /* keep the tail */
    memcpy(stub_out + stub_out_len, buf, n);
    stub_out_len += n;
    stub_out[stub_out_len] = 0;
}
uint16_t lk_hw_adc(uint8_t pin) { return pin < 6 ? stub_adc[pin] : 0; }
uint8_t lk_hw_ee_read(uint16_t addr) { return stub_eeprom[addr % sizeof stub_eeprom]; }
void lk_hw_ee_write(uint16_t addr, uint8_t value) {
    stub_eeprom[addr % sizeof stub_eeprom] = stub_ee_fail ? (uint8_t)~value : value;
}
void lk_hw_pulses(const uint16_t *p, uint8_t n) {
    memcpy(stub_pulses, p, n * sizeof *p);
    stub_pulse_updates++;
}
uint16_t lk_hw_mem_free(void) { return 777; }
