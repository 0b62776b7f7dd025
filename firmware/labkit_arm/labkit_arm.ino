// labkit arm firmware for an Arduino Uno (ATmega328P, 16 MHz): thin Arduino glue.
//
// Everything that can be tested on a PC lives in labkit_core.c (protocol, limits, calibration,
// segment queue, EEPROM image). This file only connects it to the hardware:
//   - Timer1 servo pulse driver (normal mode, compare-A interrupt toggling pins, like the
//     Arduino Servo library): channel c on digital pin D(2+c), 20 ms frames, 0.5 us ticks;
//   - UART at 115200 8N1: a small interrupt-driven driver with 64-byte receive and transmit rings
//     (the registers and buffer sizes of the Arduino core's Serial, without its Stream/Print classes,
//     which cost ~600 B of flash), ADC (analogRead), EEPROM (avr-libc), watchdog (500 ms);
//   - a stack canary for the free-memory report; idle sleep between interrupts.
// Protocol: docs/protocol.md. Build: `make -C firmware` (or open this folder in the Arduino IDE).
#include <Arduino.h>
#include <avr/eeprom.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include "labkit_core.h"

#define FRAME_TICKS 40000u  // 20 ms at 0.5 us per tick (prescaler 8)

static lk_t lk;
static volatile uint16_t servo_next[LK_CHANNELS];  // half-us, latched at each frame start
static uint16_t servo_cur[LK_CHANNELS];
static volatile uint32_t servo_frames;
static uint8_t servo_chan = LK_CHANNELS;  // LK_CHANNELS: waiting for the next frame start
static uint16_t servo_frame_start;
static uint32_t last_frame;
uint8_t lk_reset_flags __attribute__((section(".noinit")));

// Runs before main(): save and clear the reset cause, stop a watchdog left running by a WDT reset.
void lk_early_init(void) __attribute__((naked, used, section(".init3")));
void lk_early_init(void) {
  lk_reset_flags = MCUSR;
  MCUSR = 0;
  wdt_disable();
}

// The compare interrupt fires LEAD_TICKS before each edge and waits for the exact tick, so the
// edges do not jitter with the latency of other interrupts (UART, Timer0); one PORTD write ends
// the pulse of channel c and starts the one of channel c + 1 at the same instant.
#define LEAD_TICKS 40  // 20 us
static uint16_t servo_edge_at;  // Timer1 tick of the edge the pending compare is for

ISR(TIMER1_COMPA_vect) {
  uint8_t fall = 0, rise = 0;
  uint16_t at = servo_edge_at, next;
  if (servo_chan < LK_CHANNELS) {
    fall = (uint8_t)_BV(2 + servo_chan);
    servo_chan++;
  } else {  // start of a servo frame
    servo_frame_start = at;
    for (uint8_t c = 0; c < LK_CHANNELS; c++) servo_cur[c] = servo_next[c];
    servo_frames++;
    servo_chan = 0;
  }
  if (servo_chan < LK_CHANNELS) {
    rise = (uint8_t)_BV(2 + servo_chan);
    next = at + servo_cur[servo_chan];
  } else {
    next = servo_frame_start + FRAME_TICKS;
  }
  while ((int16_t)(TCNT1 - at) < 0) {
  }
  PORTD = (uint8_t)((PORTD & (uint8_t)~fall) | rise);
  servo_edge_at = next;
  OCR1A = next - LEAD_TICKS;
}

static void servo_begin(void) {
  DDRD |= (uint8_t)(((1u << LK_CHANNELS) - 1u) << 2);  // D2..D(1 + LK_CHANNELS) outputs
  // D2/D3 double as INT0/INT1. Their interrupts stay disabled (EIMSK = 0), but simavr polls a
  // low pin every cycle while the sense mode is "low level" (the reset value), which makes the
  // simulation ~10x slower; "any change" mode stops that and changes nothing on a real board.
  EICRA = _BV(ISC00) | _BV(ISC10);
  TCCR1A = 0;          // normal mode
  TCCR1B = _BV(CS11);  // clk/8: 0.5 us ticks
  servo_edge_at = TCNT1 + 400;
  OCR1A = servo_edge_at - LEAD_TICKS;
  TIFR1 = _BV(OCF1A);
  TIMSK1 |= _BV(OCIE1A);
}

// ---- UART: 115200 baud (U2X, UBRR 16, as the Arduino core sets it at 16 MHz), 8N1 ----
#define UART_RING 64  // power of two
static uint8_t rx_ring[UART_RING], tx_ring[UART_RING];
static volatile uint8_t rx_head, rx_tail, tx_head, tx_tail;

static void uart_begin(void) {
  UCSR0A = _BV(U2X0);
  UBRR0 = (F_CPU / 4 / 115200 - 1) / 2;
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART_RX_vect) {  // a byte that finds the ring full is dropped (the line then fails its CRC)
  uint8_t c = UDR0, next = (uint8_t)((rx_head + 1) & (UART_RING - 1));
  if (next != rx_tail) {
    rx_ring[rx_head] = c;
    rx_head = next;
  }
}

ISR(USART_UDRE_vect) {
  uint8_t t = tx_tail;
  if (t != tx_head) {
    UDR0 = tx_ring[t];
    tx_tail = t = (uint8_t)((t + 1) & (UART_RING - 1));
  }
  if (t == tx_head) UCSR0B &= (uint8_t)~_BV(UDRIE0);
}

static uint8_t uart_waiting(void) { return (uint8_t)((rx_head - rx_tail) & (UART_RING - 1)); }

static uint8_t uart_read(void) {
  uint8_t t = rx_tail, c = rx_ring[t];
  rx_tail = (uint8_t)((t + 1) & (UART_RING - 1));
  return c;
}

// ---- lk_hw_* functions used by the core ----
extern "C" {
void lk_hw_write(const char *buf, uint8_t n) {  // waits (interrupts on) while the ring is full
  while (n--) {
    uint8_t next = (uint8_t)((tx_head + 1) & (UART_RING - 1));
    while (next == tx_tail) {
    }
    tx_ring[tx_head] = (uint8_t)*buf++;
    tx_head = next;
    UCSR0B |= _BV(UDRIE0);
  }
}
uint16_t lk_hw_adc(uint8_t pin) { return (uint16_t)analogRead(pin); }
uint8_t lk_hw_ee_read(uint16_t addr) { return eeprom_read_byte((const uint8_t *)addr); }
void lk_hw_ee_write(uint16_t addr, uint8_t value) {
  wdt_reset();
  eeprom_update_byte((uint8_t *)addr, value);
}
void lk_hw_pulses(const uint16_t *pulse_hus, uint8_t n) {
  uint8_t sreg = SREG;
  cli();
  for (uint8_t c = 0; c < n && c < LK_CHANNELS; c++) servo_next[c] = pulse_hus[c];
  SREG = sreg;
}

extern uint8_t __heap_start;
#define CANARY 0xA5
uint16_t lk_hw_mem_free(void) {  // bytes above the heap start never touched by the stack
  const uint8_t *p = &__heap_start;
  uint16_t n = 0;
  while (p[n] == CANARY && (uint16_t)(p + n) < SP) n++;
  return n;
}
}

static void paint_stack(void) {
  uint8_t *p = &__heap_start;
  uint8_t *top = (uint8_t *)SP - 32;  // leave the live stack alone
  while (p < top) *p++ = CANARY;
}

static uint8_t reset_cause(void) {
  if (lk_reset_flags & _BV(WDRF)) return LK_RESET_WATCHDOG;
  if (lk_reset_flags & _BV(BORF)) return LK_RESET_BROWNOUT;
  if (lk_reset_flags & _BV(EXTRF)) return LK_RESET_EXTERNAL;
  return LK_RESET_POWER;
}

void setup() {
  paint_stack();
  uart_begin();
  lk_init(&lk, reset_cause(), millis(), micros());
  servo_begin();
  wdt_enable(WDTO_500MS);
}

void loop() {
  wdt_reset();
  uint8_t n = uart_waiting();
  while (n--) lk_rx(&lk, uart_read(), millis());
  uint8_t sreg = SREG;
  cli();
  uint32_t f = servo_frames;
  SREG = sreg;
  if (f != last_frame) {  // frame f started: program frame f + 1
    last_frame = f;
    lk_frame(&lk, f + 1);
  }
  lk_poll(&lk, millis(), micros());
  // Idle until the next interrupt (Timer0 tick every 1.024 ms, UART, servo edge) unless work is
  // pending. `sei; sleep` is atomic on AVR, so a wake-up cannot be lost between check and sleep.
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  if (rx_head == rx_tail && servo_frames == last_frame) {
    sleep_enable();
    sei();
    sleep_cpu();
    sleep_disable();
  }
  sei();
}
