/* labkit arm firmware: hardware-independent core (protocol v2, docs/protocol.md).
 *
 * Plain C99, no Arduino headers: the same file builds for the ATmega328P (avr-gcc, Arduino IDE)
 * and on the host (gcc/clang) for unit tests and fuzzing. The glue (labkit_arm.ino) feeds bytes,
 * servo-frame ticks and the clock in, and provides the lk_hw_* functions declared below.
 */
#ifndef LABKIT_CORE_H
#define LABKIT_CORE_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define LK_FW_VERSION "3.0.0"
#define LK_PROTO_VERSION 3 /* 3: every line sealed with a CRC-32 (*HHHHHHHH) */
#ifndef LK_JOINTS
#define LK_JOINTS 3 /* arm joints (seed arm: 3), at most 5 */
#endif
#define LK_CHANNELS (LK_JOINTS + 1) /* + gripper, on channel LK_JOINTS */
#ifndef LK_QUEUE
#define LK_QUEUE 6 /* segment queue depth */
#endif
#define LK_MAXLINE 164  /* longest accepted line, bytes before EOL */
#define LK_FRAME_MS 20  /* servo frame period */
#define LK_USER_POT_PIN 5
#define LK_SERVO_FULL 18000 /* servo travel in wire units: a hobby servo's 180 deg in centidegrees, an RC linear
                               servo's stroke in 1/18000 (docs/protocol.md 3); below, "cdeg" means a joint's unit */
#define LK_MAX_ORDER 5
#ifndef LK_SEEN
#define LK_SEEN 4 /* accepted sealed requests remembered to answer repeats (docs/protocol.md 2.1) */
#endif
#define LK_SCRATCH ((LK_MAXLINE + 1) / 4) /* int32 words: 6 pending halves of a quintic */

#if LK_JOINTS < 1 || LK_JOINTS > 5
#error "LK_JOINTS must be 1..5"
#endif

enum lk_error {
    LK_E_BADCHK = 1, LK_E_SYNTAX = 2, LK_E_UNKNOWN = 3, LK_E_TOOLONG = 4, LK_E_RANGE = 5,
    LK_E_LIMIT = 6, LK_E_QFULL = 7, LK_E_BUSY = 8, LK_E_DISCONT = 9, LK_E_EEPROM = 10, LK_E_SPEED = 11,
    LK_E_STALE = 12
};
enum lk_state { LK_IDLE = 0, LK_RUN = 1, LK_HOLD = 2 };
enum lk_flag {
    LK_F_EEPROM_DEFAULTS = 0x01, LK_F_TIMEOUT_HOLD = 0x02, LK_F_CLAMPED = 0x04,
    LK_F_WATCHDOG_RESET = 0x08, LK_F_INPUT_LOST = 0x10
};
enum lk_reset { LK_RESET_POWER = 0, LK_RESET_EXTERNAL = 1, LK_RESET_WATCHDOG = 2, LK_RESET_BROWNOUT = 3 };

typedef struct {
    int16_t pmin, pmax; /* pulse width [us] at the ends of the servo's travel (0 and 180 deg; a linear servo's stroke) */
    int16_t zero;       /* servo angle at q = 0 [cdeg] */
    int8_t dir;         /* +1 / -1 */
    int16_t lo, hi;     /* joint limits [cdeg] */
} lk_cal_t;

typedef struct {
    int32_t c[LK_JOINTS][LK_MAX_ORDER + 1]; /* cdeg, over normalised time s = t/T */
    uint16_t dur_ms;
    uint8_t order;
} lk_seg_t;

typedef struct {
    uint32_t echo;      /* echo p= (CRC-32 of what was parsed) of an accepted sealed request */
    uint16_t seq;       /* and its #seq */
    uint16_t v;         /* its reply's one integer field (0..60000), or LK_NO_FIELD (the reply is regenerated) */
} lk_seen_t;
#define LK_NO_FIELD 0xFFFFu

typedef struct {
    /* small fields first: the AVR reaches lk->field in one instruction only within 63 bytes of lk */
    uint8_t state, flags;
    uint8_t q_head, q_count;
    uint8_t len;
    uint8_t overflow, badchar;
    uint8_t body;                /* 1: the line's body has begun (past leading blanks and '$'): its bytes are checksummed */
    uint8_t stream_hz, stream_arm;
    uint8_t seen_n, seen_w;      /* valid entries of seen, next entry to overwrite */
    uint8_t window;              /* 1: a sealed request was accepted since power-up or HELLO: last_seq is the newest */
    uint16_t frame_counter;
    uint16_t timeout_ms;
    uint16_t grip_us;
    uint16_t last_seq;           /* #seq of the last accepted sealed request */
    uint32_t now_ms;
    uint32_t rx_crc, star_crc;   /* CRC-32 of the line's body so far, and of the body before its last '*' */
    uint32_t last_accept_ms;
    uint32_t done;
    uint32_t seg_start_ms;       /* frame clock: start of the active segment */
    uint32_t next_frame_ms;      /* frame clock: start of the next frame to be programmed */
    uint32_t stream_next_us, stream_period_us;
    /* commanded state */
    int32_t q[LK_JOINTS];        /* cdeg */
    int32_t tail_q[LK_JOINTS];   /* end point of the last queued segment [cdeg] */
    uint16_t pulse_hus[LK_CHANNELS]; /* pulse widths in half microseconds */
    lk_seen_t seen[LK_SEEN];     /* the last LK_SEEN accepted sealed requests (a repeat is answered, not run) */
    /* configuration (EEPROM; also timeout_ms) */
    lk_cal_t cal[LK_CHANNELS];
    uint32_t vmax[LK_JOINTS];    /* joint speed limits [cdeg/s], 0: unchecked */
    uint32_t amax[LK_JOINTS];    /* joint acceleration limits [cdeg/s^2], 0: unchecked */
    /* line input; once a request is parsed the line is scratch for the motion checks */
    union {
        char line[LK_MAXLINE + 1];
        int32_t scratch[LK_SCRATCH];
    };
    /* trajectory */
    lk_seg_t queue[LK_QUEUE];
} lk_t;

/* ---- provided by the glue (Arduino) or by the host test harness ---- */
void lk_hw_write(const char *buf, uint8_t n);     /* queue bytes for the UART */
uint16_t lk_hw_adc(uint8_t pin);                  /* 0..1023 */
uint8_t lk_hw_ee_read(uint16_t addr);
void lk_hw_ee_write(uint16_t addr, uint8_t value); /* may block; feeds the watchdog */
void lk_hw_pulses(const uint16_t *pulse_hus, uint8_t n); /* new pulse widths, half us */
uint16_t lk_hw_mem_free(void);                    /* smallest free stack/heap gap seen */

/* ---- core API ---- */
void lk_init(lk_t *lk, uint8_t reset_cause, uint32_t now_ms, uint32_t now_us);
void lk_rx(lk_t *lk, uint8_t byte, uint32_t now_ms); /* one received byte */
void lk_frame(lk_t *lk, uint32_t frame_index);       /* program servo frame #frame_index */
void lk_poll(lk_t *lk, uint32_t now_ms, uint32_t now_us); /* timeout, feedback stream */

/* helpers exposed for unit tests */
uint32_t lk_crc32(const uint8_t *data, uint16_t n); /* CRC-32/ISO-HDLC (zlib.crc32) */
/* q(s) [cdeg] at s = s24 / 2^24 (0 <= s24 <= 2^24), rounded to the nearest cdeg (integer Horner: before rounding
   within 1/4 cdeg of the exact value for |c_i| <= 10^5; exact at s = 0 and 1) */
int32_t lk_poly(const int32_t *c, uint8_t order, int32_t s24);
/* one joint's motion check on 0 <= s <= 1 (docs/protocol.md 4.3), exact or conservative: kind 0 lo <= q(s) <= hi,
   1 |dq/ds| <= x y / 1000, 2 |d2q/ds2| <= x y / 10^6 [cdeg, normalised time]; 1 if proven, 0 if not.
   |c_i| <= 10^7, x <= 4 10^8 (LIMITS: vmax <= 10^6, amax <= 10^8), y < 2^32; scratch: LK_SCRATCH words */
uint8_t lk_check(const int32_t *c, uint8_t order, uint8_t kind, int32_t lo, int32_t hi, uint32_t x, uint32_t y, int32_t *scratch);
uint8_t lk_pulse_for(const lk_cal_t *cal, int32_t q, uint16_t *hus); /* 1 ok, 0 outside servo range */
uint16_t lk_ee_save(const lk_t *lk);  /* bytes written */
uint8_t lk_ee_load(lk_t *lk);         /* 1 if a valid image was loaded */
void lk_defaults(lk_t *lk);

#ifdef __cplusplus
}
#endif
#endif
