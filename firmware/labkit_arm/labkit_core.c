/* labkit arm firmware core: protocol v2 parser, limits, calibration, segment queue, EEPROM image.
 * See labkit_core.h and docs/protocol.md. No Arduino headers; avr-libc's pgmspace only on AVR. */
#include "labkit_core.h"

#include <string.h>

#ifdef __AVR__
#include <avr/pgmspace.h>
#define LK_P(s) PSTR(s)
#define LK_RD(p) ((char)pgm_read_byte(p))
#define LK_FLASH PROGMEM
#define pgm_byte(p) pgm_read_byte(p)
#define LK_RD32(p) pgm_read_dword(p)
#else
#define pgm_byte(p) (*(p))
#define LK_RD32(p) (*(p))
#define LK_P(s) (s)
#define LK_RD(p) (*(const char *)(p))
#define LK_FLASH
#endif

#if defined(__GNUC__)
#define LK_NOINLINE __attribute__((noinline))
#else
#define LK_NOINLINE
#endif

#define LK_MAXARGS (2 + LK_JOINTS * (LK_MAX_ORDER + 1))
#define LK_COEF_MAX 10000000L
#define LK_DISCONT_CDEG 50
#define LK_EE_VERSION 3 /* 3: sealed with the line checksum, CRC-32 */
#define LK_EE_SIZE (4 + 11 * LK_CHANNELS + 8 * LK_JOINTS + 2 + 4)
#define LK_VMAX_DEFAULT 60000UL
#define LK_VMAX_MAX 1000000UL   /* 10000 deg/s */
#define LK_AMAX_MAX 100000000UL /* 10^6 deg/s^2 */ /* factory speed limit [cdeg/s]: 600 deg/s, above any hobby servo */

/* ------------------------------------------------------------------ output */
static uint32_t g_cs;   /* running CRC-32 register of the board line being written (not yet complemented) */
static uint8_t g_echo_on; /* 1: OK replies carry p=<g_echo> (sealed, state-changing requests) */
static uint32_t g_echo;
static uint16_t g_field; /* the one integer field of the OK reply being written (ok_int), or LK_NO_FIELD */

/* CRC-32/ISO-HDLC (zlib's: polynomial 0x04C11DB7 reflected, register starting at 0xFFFFFFFF, complemented at the
   end), one byte at a time. The 256-entry byte table (1 KB) is linear in the byte, T[x] = T[x & 15] ^ T[x & 0xF0],
   so two 16-entry halves of it do (128 B): entries 0..15 are T[0..15], entries 16..31 are T[0x00, 0x10 .. 0xF0].
   On the AVR the register's shift by 8 is byte moves: about 50 cycles a byte. */
static const uint32_t crc_table[32] LK_FLASH = {
    0x00000000UL, 0x77073096UL, 0xEE0E612CUL, 0x990951BAUL, 0x076DC419UL, 0x706AF48FUL, 0xE963A535UL, 0x9E6495A3UL,
    0x0EDB8832UL, 0x79DCB8A4UL, 0xE0D5E91EUL, 0x97D2D988UL, 0x09B64C2BUL, 0x7EB17CBDUL, 0xE7B82D07UL, 0x90BF1D91UL,
    0x00000000UL, 0x1DB71064UL, 0x3B6E20C8UL, 0x26D930ACUL, 0x76DC4190UL, 0x6B6B51F4UL, 0x4DB26158UL, 0x5005713CUL,
    0xEDB88320UL, 0xF00F9344UL, 0xD6D6A3E8UL, 0xCB61B38CUL, 0x9B64C2B0UL, 0x86D3D2D4UL, 0xA00AE278UL, 0xBDBDF21CUL};
static LK_NOINLINE uint32_t crc_step(uint32_t crc, uint8_t b) {
    uint8_t x = (uint8_t)crc ^ b;
    return (crc >> 8) ^ LK_RD32(&crc_table[x & 15]) ^ LK_RD32(&crc_table[16 + (x >> 4)]);
}

static void out_n(const char *s, uint8_t n) {
    uint8_t i;
    for (i = 0; i < n; i++) g_cs = crc_step(g_cs, (uint8_t)s[i]);
    lk_hw_write(s, n);
}
static void out_c(char c) { out_n(&c, 1); }
static void out_p(const char *p) { /* string in program memory */
    char c;
    while ((c = LK_RD(p++)) != 0) out_c(c);
}
static const uint32_t pow10[] LK_FLASH = {1000000000UL, 100000000UL, 10000000UL, 1000000UL, 100000UL, 10000UL, 1000UL, 100UL, 10UL};
static void out_u(uint32_t v) { /* by subtracting powers of ten: a 32-bit division costs ~40 us on the AVR */
    char b[10];
    uint8_t n = 0, i;
    for (i = 0; i < 9; i++) {
        uint32_t p = LK_RD32(&pow10[i]);
        char d = '0';
        while (v >= p) { v -= p; d++; }
        if (d > '0' || n) b[n++] = d;
    }
    b[n++] = (char)('0' + v);
    out_n(b, n);
}
static void out_i(int32_t v) {
    if (v < 0) { out_c('-'); out_u((uint32_t)(-(v + 1)) + 1u); }
    else out_u((uint32_t)v);
}
static void out_sp_i(int32_t v) { out_c(' '); out_i(v); }
static LK_NOINLINE void out_kv(const char *key_p, uint32_t v) { out_p(key_p); out_u(v); } /* " key=v" */
static char hexdigit(uint8_t v) { return (char)(v < 10 ? '0' + v : 'A' + v - 10); }
static void out_begin(void) { g_cs = 0xFFFFFFFFUL; }
static LK_NOINLINE void hex8(char *b, uint32_t v) { /* eight upper-case hex digits */
    uint8_t i;
    for (i = 8; i--; v >>= 4) b[i] = hexdigit((uint8_t)(v & 15));
}
static void out_end(void) {
    char b[11];
    b[0] = '*'; hex8(b + 1, ~g_cs); b[9] = '\r'; b[10] = '\n';
    lk_hw_write(b, 11);
}
static void out_seq(int32_t seq) {
    if (seq >= 0) out_kv(LK_P(" #"), (uint32_t)seq);
}
static void ok_begin(int32_t seq, const char *name_p) {
    out_begin(); out_p(LK_P("OK")); out_seq(seq); out_c(' '); out_p(name_p);
    if (g_echo_on) { char b[8]; out_p(LK_P(" p=")); hex8(b, g_echo); out_n(b, 8); }
}
/* word k (from 0) of a list of NUL-separated words in program memory */
static LK_NOINLINE const char *nth_word(const char *list_p, uint8_t k) {
    while (k--) while (LK_RD(list_p++)) {}
    return list_p;
}
/* error names, in code order from 1 */
static const char error_names[] LK_FLASH =
    "BADCHK\0SYNTAX\0UNKNOWN\0TOOLONG\0RANGE\0LIMIT\0QFULL\0BUSY\0DISCONT\0EEPROM\0SPEED\0STALE";
static void err_begin(int32_t seq, uint8_t code) {
    out_begin(); out_p(LK_P("ERR")); out_seq(seq); out_kv(LK_P(" "), code); out_c(' ');
    out_p(nth_word(error_names, (uint8_t)(code - 1)));
}
static void err_msg(int32_t seq, uint8_t code, const char *msg_p) {
    err_begin(seq, code);
    if (msg_p) { out_c(' '); out_p(msg_p); }
    out_end();
}
/* one request being handled: its #seq (-1: none), integer arguments and command */
typedef struct {
    int32_t seq;
    uint8_t argc;
    int32_t *a;
    const char *name; /* the command's name in its table entry (program memory): the OK reply's first word */
} call_t;
static LK_NOINLINE void ok_head(const call_t *c) { ok_begin(c->seq, c->name); } /* "OK [#seq] NAME [p=HHHHHHHH]" */
static LK_NOINLINE uint8_t ok_int(const call_t *c, int32_t v) { /* "OK ... NAME v"; returns 1 */
    g_field = (uint16_t)v; /* every such v of a sealed request fits: free slots, us, ms (<= 60000), Hz, bytes */
    ok_head(c); out_sp_i(v); out_end();
    return 1;
}
static LK_NOINLINE uint8_t reject(const call_t *c, uint8_t code, const char *msg_p) { /* returns 0 */
    err_msg(c->seq, code, msg_p);
    return 0;
}
static uint8_t err_joint(const call_t *c, uint8_t code, uint8_t j) { /* "ERR ... joint <j>"; returns 0 */
    err_begin(c->seq, code); out_p(LK_P(" joint ")); out_u(j); out_end();
    return 0;
}
static const char s_arguments[] LK_FLASH = "arguments";
#define LK_STR2(x) #x
#define LK_STR(x) LK_STR2(x)
static const char s_ident[] LK_FLASH = "fw=" LK_FW_VERSION " proto=" LK_STR(LK_PROTO_VERSION) " joints=" LK_STR(LK_JOINTS);
static const char s_gripper[] LK_FLASH = "gripper";

/* ------------------------------------------------------------------ helpers */
uint32_t lk_crc32(const uint8_t *d, uint16_t n) { /* CRC-32/ISO-HDLC: lk_crc32("123456789", 9) = 0xCBF43926 */
    uint32_t crc = 0xFFFFFFFFUL;
    while (n--) crc = crc_step(crc, *d++);
    return ~crc;
}

int32_t lk_poly(const int32_t *c, uint8_t order, int32_t s) {
    int32_t v = c[order] * 16; /* Horner in 1/16 cdeg: |v| <= 16 sum |c_i| < 2^30 */
    while (order--) v = (int32_t)(((int64_t)v * s + (1L << 23)) >> 24) + c[order] * 16;
    return (v + 8) >> 4;
}

static int32_t div_round(int32_t num, int32_t den) { /* den > 0 */
    return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

uint8_t lk_pulse_for(const lk_cal_t *cal, int32_t q, uint16_t *hus) {
    int32_t servo = (int32_t)cal->zero + (int32_t)cal->dir * q;
    if (servo < 0 || servo > LK_SERVO_FULL) return 0;
    *hus = (uint16_t)(2L * cal->pmin + div_round(servo * 2L * ((int32_t)cal->pmax - cal->pmin), LK_SERVO_FULL));
    return 1;
}

/* feasible joint interval: limits intersected with the servo range; returns 0 if empty */
static uint8_t feasible(const lk_cal_t *cal, int32_t *lo, int32_t *hi) {
    int32_t a, b;
    if (cal->dir > 0) { a = -(int32_t)cal->zero; b = LK_SERVO_FULL - (int32_t)cal->zero; }
    else { a = (int32_t)cal->zero - LK_SERVO_FULL; b = cal->zero; }
    *lo = a > cal->lo ? a : cal->lo;
    *hi = b < cal->hi ? b : cal->hi;
    return *lo <= *hi;
}

static uint8_t joint_ok(const lk_cal_t *cal, int32_t q) {
    uint16_t h;
    return q >= cal->lo && q <= cal->hi && lk_pulse_for(cal, q, &h);
}

static LK_NOINLINE uint8_t grip_ok(const lk_cal_t *cal, int32_t us) {
    int32_t a = cal->pmin < cal->pmax ? cal->pmin : cal->pmax;
    int32_t b = cal->pmin < cal->pmax ? cal->pmax : cal->pmin;
    return us >= a && us <= b;
}

static void update_pulses(lk_t *lk) {
    uint8_t j;
    for (j = 0; j < LK_JOINTS; j++)
        (void)lk_pulse_for(&lk->cal[j], lk->q[j], &lk->pulse_hus[j]); /* q is always kept valid */
    lk->pulse_hus[LK_JOINTS] = (uint16_t)(2u * lk->grip_us);
    lk_hw_pulses(lk->pulse_hus, LK_CHANNELS);
}

/* ------------------------------------------------------------------ EEPROM */
static void default_cal(lk_cal_t *cal, uint16_t *timeout_ms) {
    uint8_t c;
    for (c = 0; c < LK_CHANNELS; c++) {
        cal[c].pmin = 500; cal[c].pmax = 2500; cal[c].zero = 0;
        cal[c].dir = 1; cal[c].lo = 0; cal[c].hi = LK_SERVO_FULL;
    }
    *timeout_ms = 500;
}

void lk_defaults(lk_t *lk) {
    uint8_t j;
    default_cal(lk->cal, &lk->timeout_ms);
    for (j = 0; j < LK_JOINTS; j++) { lk->vmax[j] = LK_VMAX_DEFAULT; lk->amax[j] = 0; }
}

static int16_t get16(const uint8_t *b) { return (int16_t)(b[0] | ((uint16_t)b[1] << 8)); }

/* The image's fields in order (docs/protocol.md 6): a calibration's pmin pmax zero dir lo hi, then vmax amax per
   joint, then the timeout, each little-endian like the integers of both targets (the ATmega328P and the x86/ARM
   hosts of the tests), so one walk copies them either way: to the image (save) or from it (load) */
#define LK_OFF(f) ((uint8_t)__builtin_offsetof(lk_cal_t, f)) /* gcc, avr-gcc and clang; no <stddef.h> needed */
static const uint8_t cal_field[] LK_FLASH = {
    LK_OFF(pmin), 2, LK_OFF(pmax), 2, LK_OFF(zero), 2, LK_OFF(dir), 1, LK_OFF(lo), 2, LK_OFF(hi), 2};
static uint8_t *ee_copy(uint8_t *p, void *v, uint8_t n, uint8_t save) {
    if (save) memcpy(p, v, n); else memcpy(v, p, n);
    return p + n;
}
static void ee_walk(lk_t *lk, uint8_t *b, uint8_t save) {
    uint8_t c, f, *p = b + 4;
    for (c = 0; c < LK_CHANNELS; c++)
        for (f = 0; f < sizeof cal_field; f += 2)
            p = ee_copy(p, (uint8_t *)&lk->cal[c] + pgm_byte(&cal_field[f]), pgm_byte(&cal_field[f + 1]), save);
    for (c = 0; c < LK_JOINTS; c++) { p = ee_copy(p, &lk->vmax[c], 4, save); p = ee_copy(p, &lk->amax[c], 4, save); }
    ee_copy(p, &lk->timeout_ms, 2, save);
}
typedef char lk_ee_layout[(int)(4 + 11 * LK_CHANNELS + 8 * LK_JOINTS + 2 + 4) == LK_EE_SIZE ? 1 : -1];

uint16_t lk_ee_save(const lk_t *lk) {
    uint8_t b[LK_EE_SIZE];
    uint16_t i;
    uint32_t crc;
    b[0] = 'L'; b[1] = 'K'; b[2] = LK_EE_VERSION; b[3] = LK_CHANNELS;
    ee_walk((lk_t *)lk, b, 1); /* reads lk only */
    crc = lk_crc32(b, LK_EE_SIZE - 4);
    memcpy(b + LK_EE_SIZE - 4, &crc, 4); /* little-endian on both targets, like every field */
    for (i = 0; i < LK_EE_SIZE; i++) lk_hw_ee_write(i, b[i]);
    for (i = 0; i < LK_EE_SIZE; i++)
        if (lk_hw_ee_read(i) != b[i]) return 0;
    return LK_EE_SIZE;
}

static uint8_t cal_valid(const lk_cal_t *k) {
    return k->pmin >= 400 && k->pmin <= 2600 && k->pmax >= 400 && k->pmax <= 2600 && k->pmin != k->pmax &&
           k->zero >= -32000 && k->zero <= 32000 && (k->dir == 1 || k->dir == -1) &&
           k->lo >= -32000 && k->hi <= 32000 && k->lo <= k->hi;
}

static uint8_t timeout_valid(int32_t t) { return t == 0 || (t >= 50 && t <= 60000); }

/* loads straight into lk: on 0 (no valid image) the caller sets the factory defaults over whatever was copied */
uint8_t lk_ee_load(lk_t *lk) {
    uint8_t b[LK_EE_SIZE], c;
    uint16_t i;
    int32_t lo, hi;
    uint32_t crc;
    for (i = 0; i < LK_EE_SIZE; i++) b[i] = lk_hw_ee_read(i);
    if (b[0] != 'L' || b[1] != 'K' || b[2] != LK_EE_VERSION || b[3] != LK_CHANNELS) return 0;
    memcpy(&crc, b + LK_EE_SIZE - 4, 4);
    if (crc != lk_crc32(b, LK_EE_SIZE - 4)) return 0;
    ee_walk(lk, b, 0); /* vmax, amax: the CRC vouches for them */
    for (c = 0; c < LK_CHANNELS; c++)
        if (!cal_valid(&lk->cal[c]) || (c < LK_JOINTS && !feasible(&lk->cal[c], &lo, &hi))) return 0;
    return timeout_valid(lk->timeout_ms);
}

/* ------------------------------------------------------------------ state changes */
static void home(lk_t *lk) {
    uint8_t j;
    int32_t lo, hi;
    for (j = 0; j < LK_JOINTS; j++) {
        feasible(&lk->cal[j], &lo, &hi);
        lk->q[j] = lo + (hi - lo) / 2;
    }
    lk->grip_us = (uint16_t)((lk->cal[LK_JOINTS].pmin + lk->cal[LK_JOINTS].pmax) / 2);
    update_pulses(lk);
}

void lk_init(lk_t *lk, uint8_t reset_cause, uint32_t now_ms, uint32_t now_us) {
    uint8_t ok;
    memset(lk, 0, sizeof *lk);
    lk->now_ms = now_ms;
    lk->stream_next_us = now_us;
    lk->last_accept_ms = now_ms;
    ok = lk_ee_load(lk);
    if (!ok) { lk_defaults(lk); lk->flags |= LK_F_EEPROM_DEFAULTS; }
    if (reset_cause == LK_RESET_WATCHDOG) lk->flags |= LK_F_WATCHDOG_RESET;
    home(lk);
    out_begin();
    out_p(LK_P("READY labkit-arm " LK_STR(LK_PROTO_VERSION) " ")); out_p(s_ident);
    out_p(LK_P(" reset="));
    out_p(nth_word(LK_P("POWER\0EXTERNAL\0WATCHDOG\0BROWNOUT"), reset_cause <= LK_RESET_BROWNOUT ? reset_cause : 0));
    out_p(LK_P(" eeprom=")); out_p(ok ? LK_P("OK") : LK_P("DEFAULTS"));
    out_end();
}

/* " a0 a1 ... pot" (the joint potentiometers, then the user's) and the line's end: FB and READ */
static LK_NOINLINE void out_adc(void) {
    uint8_t j;
    for (j = 0; j < LK_JOINTS; j++) out_sp_i(lk_hw_adc(j));
    out_sp_i(lk_hw_adc(LK_USER_POT_PIN));
    out_end();
}

static void out_q(const lk_t *lk) {
    uint8_t j;
    for (j = 0; j < LK_JOINTS; j++) out_sp_i(lk->q[j]);
}

static void halt(lk_t *lk) { lk->q_count = 0; lk->state = LK_IDLE; }

static void clamp_set(lk_t *lk, uint8_t j, int32_t q) {
    int32_t lo, hi;
    feasible(&lk->cal[j], &lo, &hi);
    if (q < lo) { q = lo; lk->flags |= LK_F_CLAMPED; }
    if (q > hi) { q = hi; lk->flags |= LK_F_CLAMPED; }
    lk->q[j] = q;
}

void lk_frame(lk_t *lk, uint32_t frame_index) {
    uint32_t t = frame_index * LK_FRAME_MS;
    uint8_t j;
    lk->next_frame_ms = t + LK_FRAME_MS;
    if (lk->state != LK_RUN) return;
    for (;;) {
        lk_seg_t *seg = &lk->queue[lk->q_head];
        uint32_t el = t - lk->seg_start_ms;
        if (el < seg->dur_ms) { /* s = floor(el 2^24 / dur) in two 32-bit long-division steps (el < dur < 2^16) */
            uint32_t hi = (el << 8) / seg->dur_ms, rem = (el << 8) - hi * seg->dur_ms;
            int32_t s = (int32_t)((hi << 16) | ((rem << 16) / seg->dur_ms));
            for (j = 0; j < LK_JOINTS; j++) clamp_set(lk, j, lk_poly(seg->c[j], seg->order, s));
            break;
        }
        lk->done++;
        if (lk->q_count == 1) {
            for (j = 0; j < LK_JOINTS; j++) clamp_set(lk, j, lk_poly(seg->c[j], seg->order, 1L << 24));
            halt(lk);
            out_begin(); out_kv(LK_P("EV DONE "), lk->done); out_end();
            break;
        }
        lk->seg_start_ms += seg->dur_ms;
        lk->q_head = (uint8_t)((lk->q_head + 1) % LK_QUEUE);
        lk->q_count--;
    }
    update_pulses(lk);
}

void lk_poll(lk_t *lk, uint32_t now_ms, uint32_t now_us) {
    lk->now_ms = now_ms;
    if (lk->state == LK_RUN && lk->timeout_ms && (now_ms - lk->last_accept_ms) > lk->timeout_ms) {
        halt(lk);
        lk->state = LK_HOLD;
        lk->flags |= LK_F_TIMEOUT_HOLD;
        out_begin(); out_p(LK_P("EV HOLD")); out_q(lk); out_end();
    }
    if (lk->stream_arm) { lk->stream_arm = 0; lk->stream_next_us = now_us; }
    if (lk->stream_hz) {
        int32_t late = (int32_t)(now_us - lk->stream_next_us);
        if (late >= 0) {
            uint32_t missed;
            out_begin(); out_kv(LK_P("FB "), lk->frame_counter); out_kv(LK_P(" "), now_ms);
            out_adc();
            missed = (uint32_t)late / lk->stream_period_us; /* whole periods skipped (board busy) */
            lk->frame_counter = (uint16_t)(lk->frame_counter + 1 + missed);
            lk->stream_next_us += (1 + missed) * lk->stream_period_us;
        }
    }
}

/* ------------------------------------------------------------------ parsing */
static uint8_t is_ws(char c) { return c == ' ' || c == '\t'; }
static uint8_t hexval(char c) {
    if (c >= '0' && c <= '9') return (uint8_t)(c - '0');
    if (c >= 'A' && c <= 'F') return (uint8_t)(c - 'A' + 10);
    if (c >= 'a' && c <= 'f') return (uint8_t)(c - 'a' + 10);
    return 0xFF;
}

static char *next_token(char **p) {
    char *s = *p, *t;
    while (*s && is_ws(*s)) s++;
    if (!*s) { *p = s; return 0; }
    t = s;
    while (*s && !is_ws(*s)) s++;
    if (*s) *s++ = 0;
    *p = s;
    return t;
}

static uint8_t parse_int(const char *s, int32_t *out) {
    uint32_t v = 0;
    uint8_t neg = 0, n = 0;
    if (*s == '+' || *s == '-') neg = (*s++ == '-');
    while (*s >= '0' && *s <= '9') {
        uint8_t d = (uint8_t)(*s++ - '0');
        /* overflow check without a division (32-bit divisions cost ~40 us each on the AVR) */
        if (++n > 10 || v > 214748364u || (v == 214748364u && d > 7)) return 0;
        v = v * 10u + d;
    }
    if (!n || *s) return 0;
    *out = neg ? -(int32_t)v : (int32_t)v;
    return 1;
}

static uint8_t name_is(const char *tok, const char *name_p) {
    char a, b;
    do {
        a = *tok++; b = LK_RD(name_p++);
        if (a >= 'a' && a <= 'z') a = (char)(a - 32);
        if (a != b) return 0;
    } while (b);
    return 1;
}

/* ------------------------------------------------------------------ commands */
static const char s_busy[] LK_FLASH = "STOP first";
static uint8_t busy(lk_t *lk, const call_t *c) {
    if (lk->state != LK_RUN) return 0;
    err_msg(c->seq, LK_E_BUSY, s_busy);
    return 1;
}

static uint8_t cmd_status(lk_t *lk, call_t *c) {
    uint8_t j;
    ok_head(c); out_p(LK_P(" state="));
    out_p(nth_word(LK_P("IDLE\0RUN\0HOLD"), lk->state)); /* enum lk_state order */
    out_p(LK_P(" q="));
    for (j = 0; j < LK_JOINTS; j++) { if (j) out_c(','); out_i(lk->q[j]); }
    out_kv(LK_P(" grip="), lk->grip_us);
    out_kv(LK_P(" queue="), lk->q_count);
    out_kv(LK_P(" free="), LK_QUEUE - lk->q_count);
    out_kv(LK_P(" done="), lk->done);
    out_kv(LK_P(" timeout="), lk->timeout_ms);
    out_kv(LK_P(" stream="), lk->stream_hz);
    out_p(LK_P(" flags=")); out_c(hexdigit(lk->flags >> 4)); out_c(hexdigit(lk->flags & 15));
    out_kv(LK_P(" mem="), lk_hw_mem_free());
    out_kv(LK_P(" t="), lk->now_ms);
    out_kv(LK_P(" last="), lk->last_seq);
    out_end();
    return 1;
}

static uint8_t check_joints(lk_t *lk, const call_t *c, const int32_t *q, const lk_cal_t *cal) {
    uint8_t j;
    for (j = 0; j < LK_JOINTS; j++) {
        if (!joint_ok(&cal[j], q[j])) {
            return err_joint(c, LK_E_LIMIT, j);
        }
    }
    (void)lk;
    return 1;
}

/* Motion checks (docs/protocol.md 4.3): exact or conservative, in integers, so that the virtual board and the
   host (labkit/arm/_motion.py, the same steps on Python integers) refuse exactly what this board refuses.
   On 0 <= s <= 1 a polynomial lies in the hull of its Bernstein coefficients, the first and last being its end
   values; those of q' and q'' are differences of those of q. A hull inside the limit proves the check, an end value
   outside refutes it; otherwise the polynomial is halved (de Casteljau) at most LK_SUB_DEPTH times, in int32
   scaled to 29 bits with every average rounded down, so that a stored coefficient never exceeds the true one
   and falls short by less than e = 1 + level m: a piece passes when -lim <= c and c + e <= lim for all its
   coefficients c; a piece still undecided at the deepest level fails the check (conservative). */
#define LK_SUB_DEPTH 6
typedef char lk_scratch_fits[LK_SCRATCH >= LK_SUB_DEPTH * (LK_MAX_ORDER + 1) ? 1 : -1]; /* pending halves */
/* K / C(n, i) for n = 3 (K = 3) and n = 5 (K = 10) */
static const uint8_t bern_w[] LK_FLASH = {3, 1, 1, 3, 10, 2, 1, 1, 2, 10};

/* halve p (m + 1 coefficients, |p| < 2^29) until |p| <= lim is proven (1) or refuted (0); st: pending halves */
static LK_NOINLINE uint8_t subdivide(int32_t *p, uint8_t m, int32_t lim, int8_t sh, int32_t *st) {
    uint8_t lv[LK_SUB_DEPTH], n = 0, level = 0, k, i, in;
    int32_t *r;
    for (;;) {
        int32_t e = sh < 0 || level * m > sh ? 1 + (int32_t)level * m : 0; /* bound on the rounding shortfall */
        for (in = 1, k = 0; k <= m; k++) {
            int32_t v = p[k];
            if (v < -lim || v + e > lim) {
                if ((k == 0 || k == m) && (v > lim || v + e < -lim)) return 0; /* an end value outside */
                in = 0;
            }
        }
        if (in) {
            if (!n) return 1;
            level = lv[--n];
            memcpy(p, st + n * (m + 1), (m + 1) * sizeof *p);
            continue;
        }
        if (level == LK_SUB_DEPTH) return 0; /* still undecided: refuse */
        r = st + n * (m + 1);
        memcpy(r, p, (m + 1) * sizeof *p);
        for (i = 1; i <= m; i++) {
            for (k = 0; k <= m - i; k++) r[k] = (r[k] + r[k + 1]) >> 1; /* floor of the average */
            p[i] = r[0];
        }
        lv[n++] = ++level;
    }
}

/* floor(n 2^sh / q), sh = -2..29 */
static LK_NOINLINE int32_t scaled_div(uint64_t n, int8_t sh, uint32_t q) {
    while (sh > 0) { n <<= 1; sh--; }
    while (sh < 0) { n >>= 1; sh++; }
    return (int32_t)(n / q);
}

/* max |p_k| over k = 0..m, or over the end values k = 0 and m only */
static LK_NOINLINE uint32_t max_abs(const int32_t *p, uint8_t m, uint8_t ends) {
    uint32_t big = 0, u;
    uint8_t k;
    for (k = 0; k <= m; k += ends && k < m ? m : 1) { u = (uint32_t)(p[k] < 0 ? -p[k] : p[k]); if (u > big) big = u; }
    return big;
}

/* K_n times the Bernstein coefficients of q: K b_k = sum_i C(k, i) (K / C(n, i)) c_i, scaled then n passes of
   running sums */
static LK_NOINLINE void bern(const int32_t *c, uint8_t order, int32_t *b) {
    const uint8_t *w = bern_w + (order == 3 ? 0 : 4);
    uint8_t k, i;
    for (k = 0; k <= order; k++) b[k] = (int32_t)pgm_byte(w + k) * c[k];
    for (i = 0; i < order; i++)
        for (k = order; k > i; k--) b[k] += b[k - 1];
}

/* lk_check on the coefficients bern() gave (b is overwritten) */
static LK_NOINLINE uint8_t check_bern(int32_t *b, uint8_t order, uint8_t kind, int32_t lo, int32_t hi, uint32_t x,
                                      uint32_t y, int32_t *scratch) {
    uint32_t big, q = 1;
    uint64_t n;
    uint8_t kk = order == 3 ? 3 : 10, k, i, m = order;
    int8_t sh = 0;
    if (!kind) { /* lo <= q <= hi  <=>  |2 b - K (lo + hi)| <= K (hi - lo) */
        for (k = 0; k <= m; k++) b[k] = 2 * b[k] - (int32_t)kk * (lo + hi);
        x = (uint32_t)(hi - lo); y = 1;
    } else { /* |q'| <= x y / 1000 <=> |differences| n 1000 <= K x y; q'': second differences, 10^6 n (n - 1) */
        for (i = 0; i < kind; i++, m--)
            for (k = 0; k < m; k++) b[k] = b[k + 1] - b[k];
        q = kind == 1 ? 1000UL * order : 1000000UL * order * (order - 1);
    }
    n = (uint64_t)(x * kk) * y;                          /* |b| q <= n */
    big = max_abs(b, m, 0);
    if ((uint64_t)big * q <= n) return 1;                /* the hull is inside */
    if ((uint64_t)max_abs(b, m, 1) * q > n) return 0;    /* an end value is outside */
    while (big >= (1UL << 29)) { big >>= 1; sh--; }      /* scale to 29 bits (n / q < big) */
    while (big < (1UL << 28)) { big <<= 1; sh++; }
    for (k = 0; k <= m; k++) b[k] = sh >= 0 ? (int32_t)((uint32_t)b[k] << sh) : b[k] >> -sh;
    return subdivide(b, m, scaled_div(n, sh, q), sh, scratch);
}

uint8_t lk_check(const int32_t *c, uint8_t order, uint8_t kind, int32_t lo, int32_t hi, uint32_t x, uint32_t y, int32_t *scratch) {
    int32_t b[LK_MAX_ORDER + 1];
    bern(c, order, b);
    return check_bern(b, order, kind, lo, hi, x, y, scratch);
}

/* SEG, and MOVE's cubic (move = 1: its end points were checked) */
static uint8_t queue_seg(lk_t *lk, const call_t *c, uint8_t move) {
    const int32_t *a = c->a, *cj;
    uint8_t order, j, k, slot;
    uint16_t i;
    lk_seg_t *seg;
    if (c->argc < 2) return reject(c, LK_E_SYNTAX, s_arguments);
    if (a[0] < 1 || a[0] > 60000) return reject(c, LK_E_RANGE, LK_P("duration"));
    if (a[1] != 3 && a[1] != 5) return reject(c, LK_E_RANGE, LK_P("order"));
    order = (uint8_t)a[1];
    if (c->argc != 2 + LK_JOINTS * (order + 1)) return reject(c, LK_E_SYNTAX, s_arguments);
    for (i = 2; i < c->argc; i++)
        if (a[i] > LK_COEF_MAX || a[i] < -LK_COEF_MAX) return reject(c, LK_E_RANGE, LK_P("coefficient"));
    if (lk->q_count >= LK_QUEUE) return reject(c, LK_E_QFULL, 0);
    slot = (uint8_t)((lk->q_head + lk->q_count) % LK_QUEUE);
    seg = &lk->queue[slot];
    seg->dur_ms = (uint16_t)a[0];
    seg->order = order;
    for (j = 0, cj = a + 2; j < LK_JOINTS; j++, cj += order + 1) {
        int32_t lo, hi, d = cj[0] - (lk->q_count ? lk->tail_q[j] : lk->q[j]);
        memcpy(seg->c[j], cj, (order + 1) * sizeof *cj);
        /* a MOVE's end points were checked and its cubic is monotone between them: no position check */
        if (!move && (!feasible(&lk->cal[j], &lo, &hi) || !lk_check(cj, order, 0, lo, hi, 0, 0, lk->scratch)))
            return err_joint(c, LK_E_LIMIT, j);
        if (d > LK_DISCONT_CDEG || d < -LK_DISCONT_CDEG) return err_joint(c, LK_E_DISCONT, j);
    }
    for (j = 0, cj = a + 2; j < LK_JOINTS; j++, cj += order + 1) {
        int32_t b0[LK_MAX_ORDER + 1], b[LK_MAX_ORDER + 1];
        bern(cj, order, b0);
        for (k = 1; k <= 2; k++) { /* speed (vmax dur / 1000), acceleration (amax dur^2 / 10^6); 0: unchecked */
            uint32_t x = k == 1 ? lk->vmax[j] : lk->amax[j], y = k == 1 ? (uint32_t)a[0] : (uint32_t)a[0] * a[0];
            memcpy(b, b0, sizeof b);
            if (x && !check_bern(b, order, k, 0, 0, x, y, lk->scratch)) return err_joint(c, LK_E_SPEED, j);
        }
    }
    for (j = 0, cj = a + 2; j < LK_JOINTS; j++, cj += order + 1) {
        int32_t end = 0;
        for (k = 0; k <= order; k++) end += cj[k];
        lk->tail_q[j] = end;
    }
    lk->q_count++;
    if (lk->state != LK_RUN) { lk->state = LK_RUN; lk->seg_start_ms = lk->next_frame_ms; }
    return ok_int(c, LK_QUEUE - lk->q_count);
}

/* field f (0..5, cal_field order: pmin pmax zero dir lo hi) of a calibration, or set from v (truncated) */
static int16_t cal_get(const lk_cal_t *k, uint8_t f) {
    const uint8_t *p = (const uint8_t *)k + pgm_byte(&cal_field[2 * f]);
    return pgm_byte(&cal_field[2 * f + 1]) == 1 ? (int8_t)p[0] : get16(p);
}
static void cal_set(lk_cal_t *k, uint8_t f, int32_t v) { /* little-endian: the low bytes of v */
    memcpy((uint8_t *)k + pgm_byte(&cal_field[2 * f]), &v, pgm_byte(&cal_field[2 * f + 1]));
}

static void out_cal(const lk_cal_t *k) {
    uint8_t f;
    for (f = 0; f < 6; f++) out_sp_i(cal_get(k, f));
}

/* check that every current position is valid under calibration `cal` */
static uint8_t positions_valid(lk_t *lk, const call_t *c, const lk_cal_t *cal) {
    if (!check_joints(lk, c, lk->q, cal)) return 0;
    if (!grip_ok(&cal[LK_JOINTS], lk->grip_us)) return reject(c, LK_E_LIMIT, s_gripper);
    return 1;
}

static uint8_t cmd_cal(lk_t *lk, call_t *c) {
    const int32_t *a = c->a;
    lk_cal_t cal[LK_CHANNELS];
    uint8_t ch, i, fits = 1;
    if (a[0] < 0 || a[0] >= LK_CHANNELS) return reject(c, LK_E_RANGE, LK_P("channel"));
    ch = (uint8_t)a[0];
    if (c->argc == 7) {
        lk_cal_t *k = &cal[ch];
        if (busy(lk, c)) return 0;
        /* the EEPROM's rule (cal_valid) on the fields as received: every valid field is within +-32000 */
        memcpy(cal, lk->cal, sizeof cal);
        for (i = 1; i <= 6; i++) {
            if (a[i] < -32000 || a[i] > 32000) fits = 0;
            cal_set(k, (uint8_t)(i - 1), a[i]);
        }
        if (!fits || k->dir != a[4] || !cal_valid(k)) return reject(c, LK_E_RANGE, LK_P("calibration field"));
        if (!positions_valid(lk, c, cal)) return 0;
        memcpy(lk->cal, cal, sizeof cal);
        update_pulses(lk);
    }
    ok_head(c); out_sp_i(ch); out_cal(&lk->cal[ch]); out_end();
    return 1;
}

/* HELLO opens a session (docs/protocol.md 2.1): the remembered requests and the stale window are forgotten */
static uint8_t cmd_hello(lk_t *lk, call_t *c) {
    lk->seen_n = 0; lk->seen_w = 0; lk->window = 0;
    ok_head(c); out_p(LK_P(" labkit-arm ")); out_p(s_ident); out_kv(LK_P(" channels="), LK_CHANNELS);
    out_kv(LK_P(" queue="), LK_QUEUE); out_kv(LK_P(" maxline="), LK_MAXLINE); out_end();
    return 1;
}

static uint8_t cmd_ping(lk_t *lk, call_t *c) {
    ok_head(c); out_kv(LK_P(" "), lk->now_ms); out_end();
    return 1;
}

/* MOVE q... dur = one rest-to-rest cubic segment from the commanded position (c = q, 0, 3 dq, -2 dq), queued as
   that SEG: its arguments are rewritten in place into the SEG's (the array holds LK_MAXARGS >= 2 + 4 LK_JOINTS),
   last joint first so that no target is overwritten before it is read */
static uint8_t cmd_move(lk_t *lk, call_t *c) {
    int32_t *a = c->a, dur = a[LK_JOINTS];
    int8_t j;
    if (busy(lk, c) || !check_joints(lk, c, a, lk->cal)) return 0;
    for (j = LK_JOINTS - 1; j >= 0; j--) {
        int32_t *p = a + 2 + 4 * j, q0 = lk->q[j], d = a[j] - q0;
        p[0] = q0; p[1] = 0; p[2] = 3 * d; p[3] = -2 * d;
    }
    a[0] = dur; a[1] = 3; c->argc = 2 + 4 * LK_JOINTS;
    return queue_seg(lk, c, 1);
}

static uint8_t cmd_grip(lk_t *lk, call_t *c) {
    if (!grip_ok(&lk->cal[LK_JOINTS], c->a[0])) return reject(c, LK_E_RANGE, s_gripper);
    lk->grip_us = (uint16_t)c->a[0];
    update_pulses(lk);
    return ok_int(c, lk->grip_us);
}

static uint8_t cmd_seg(lk_t *lk, call_t *c) { return queue_seg(lk, c, 0); }

static uint8_t cmd_stop(lk_t *lk, call_t *c) {
    halt(lk);
    ok_head(c); out_q(lk); out_end();
    return 1;
}

static uint8_t cmd_timeout(lk_t *lk, call_t *c) {
    if (c->argc == 1) {
        if (!timeout_valid(c->a[0])) return reject(c, LK_E_RANGE, LK_P("timeout"));
        lk->timeout_ms = (uint16_t)c->a[0];
    }
    return ok_int(c, lk->timeout_ms);
}

static uint8_t cmd_read(lk_t *lk, call_t *c) {
    (void)lk;
    ok_head(c); out_adc();
    return 1;
}

static uint8_t cmd_stream(lk_t *lk, call_t *c) {
    uint8_t hz;
    if (c->a[0] < 0 || c->a[0] > 200) return reject(c, LK_E_RANGE, LK_P("rate"));
    lk->stream_hz = hz = (uint8_t)c->a[0];
    lk->frame_counter = 0;
    if (hz) { lk->stream_period_us = 1000000UL / hz; lk->stream_arm = 1; }
    return ok_int(c, hz);
}

static uint8_t cmd_defaults(lk_t *lk, call_t *c) {
    lk_cal_t cal[LK_CHANNELS];
    uint16_t timeout_ms;
    if (busy(lk, c)) return 0;
    default_cal(cal, &timeout_ms);
    if (!positions_valid(lk, c, cal)) return 0;
    memcpy(lk->cal, cal, sizeof cal);
    lk->timeout_ms = timeout_ms;
    update_pulses(lk);
    ok_head(c); out_end();
    return 1;
}

static uint8_t cmd_save(lk_t *lk, call_t *c) {
    uint16_t n;
    if (busy(lk, c)) return 0;
    n = lk_ee_save(lk);
    if (!n) return reject(c, LK_E_EEPROM, LK_P("read-back"));
    return ok_int(c, n);
}

/* LIMITS j [vmax amax] */
static uint8_t cmd_limits(lk_t *lk, call_t *c) {
    const int32_t *a = c->a;
    uint8_t j;
    if (a[0] < 0 || a[0] >= LK_JOINTS) return reject(c, LK_E_RANGE, LK_P("joint"));
    j = (uint8_t)a[0];
    if (c->argc == 3) {
        if (a[1] < 0 || (uint32_t)a[1] > LK_VMAX_MAX || a[2] < 0 || (uint32_t)a[2] > LK_AMAX_MAX)
            return reject(c, LK_E_RANGE, LK_P("limits"));
        if (busy(lk, c)) return 0;
        lk->vmax[j] = (uint32_t)a[1]; lk->amax[j] = (uint32_t)a[2];
    }
    ok_head(c); out_sp_i(j); out_sp_i((int32_t)lk->vmax[j]); out_sp_i((int32_t)lk->amax[j]); out_end();
    return 1;
}

/* The command table (docs/protocol.md section 4), in program memory: one entry per command, found by its name.
   args: the argument counts it accepts, bit n for n arguments (LK_ARGS_OWN: the handler checks them);
   read_only: may be sent without #seq and CRC (every other command must be sealed, and its OK carries p=);
   run: answers OK (returns 1: accepted) or ERR (returns 0); called only with an accepted argument count. */
typedef uint8_t (*lk_handler_t)(lk_t *lk, call_t *c);
typedef struct {
    char name[9]; /* upper case, NUL-terminated */
    uint8_t args;
    uint8_t read_only;
    lk_handler_t run;
} lk_command_t;
#define LK_ARGS(n) (1u << (n))
#define LK_ARGS_OWN 0xFF
typedef char lk_args_fit[LK_JOINTS + 1 <= 7 ? 1 : -1]; /* MOVE's argument count fits the 8-bit mask */

static const lk_command_t commands[] LK_FLASH = {
    {"HELLO", LK_ARGS(0), 1, cmd_hello},
    {"PING", LK_ARGS(0), 1, cmd_ping},
    {"STATUS", LK_ARGS(0), 1, cmd_status},
    {"MOVE", LK_ARGS(LK_JOINTS + 1), 0, cmd_move},
    {"GRIP", LK_ARGS(1), 0, cmd_grip},
    {"SEG", LK_ARGS_OWN, 0, cmd_seg},
    {"STOP", LK_ARGS(0), 0, cmd_stop},
    {"TIMEOUT", LK_ARGS(0) | LK_ARGS(1), 0, cmd_timeout},
    {"READ", LK_ARGS(0), 1, cmd_read},
    {"STREAM", LK_ARGS(1), 0, cmd_stream},
    {"CAL", LK_ARGS(1) | LK_ARGS(7), 0, cmd_cal},
    {"DEFAULTS", LK_ARGS(0), 0, cmd_defaults},
    {"SAVE", LK_ARGS(0), 0, cmd_save},
    {"LIMITS", LK_ARGS(1) | LK_ARGS(3), 0, cmd_limits},
};
#define LK_COMMANDS (sizeof commands / sizeof commands[0])

#ifdef __AVR__
#define LK_RD_HANDLER(p) ((lk_handler_t)pgm_read_word(p)) /* a function pointer is one word on the ATmega328P */
#else
#define LK_RD_HANDLER(p) (*(p))
#endif

/* the table entry named tok (any case), or 0 */
static const lk_command_t *find_command(const char *tok) {
    const lk_command_t *e;
    for (e = commands; e < commands + LK_COMMANDS; e++)
        if (name_is(tok, e->name)) return e;
    return 0;
}

/* run the command of entry e on request c: ERR 2 SYNTAX arguments for a count it does not accept (or a malformed
   number, argc 0xFF), else its handler; 1 if accepted */
static uint8_t dispatch(lk_t *lk, const lk_command_t *e, call_t *c) {
    uint8_t allowed = (uint8_t)pgm_byte(&e->args);
    if (c->argc == 0xFF || (allowed != LK_ARGS_OWN && (c->argc > 7 || !((allowed >> c->argc) & 1))))
        return reject(c, LK_E_SYNTAX, s_arguments);
    return LK_RD_HANDLER(&e->run)(lk, c);
}

/* A repeat (docs/protocol.md 2.1): a sealed request with the #seq and echo of one of the last LK_SEEN accepted
   ones is answered with that request's reply and not run: its stored integer field, or for STOP, CAL, LIMITS and
   DEFAULTS (whose fields report the state they left) the same report made now, without changing anything */
static void replay(lk_t *lk, const lk_command_t *e, call_t *c, uint16_t v) {
    lk_handler_t run = LK_RD_HANDLER(&e->run);
    if (v != LK_NO_FIELD) { ok_int(c, v); return; }
    if (run == cmd_cal || run == cmd_limits) { c->argc = 1; run(lk, c); return; } /* their report-only form */
    ok_head(c);
    if (run == cmd_stop) out_q(lk);
    out_end();
}

/* CRC of a valid integer token as the board would write it (no '+', no leading zeros, no "-0") */
static uint32_t crc_canonical(uint32_t crc, const char *t) {
    uint8_t neg = *t == '-';
    if (*t == '+' || *t == '-') t++;
    while (t[0] == '0' && t[1]) t++;
    if (neg && *t != '0') crc = crc_step(crc, '-');
    while (*t) crc = crc_step(crc, (uint8_t)*t++);
    return crc;
}

/* one complete line (no EOL): lk->line, lk->len; lk->star_crc is the CRC-32 of its body before the last '*' */
static void exec_line(lk_t *lk) {
    char *line = lk->line;
    uint8_t len = lk->len;
    char *p = line, *end = line + len, *star = 0, *r, *cmd, *tok;
    const char *name;
    const lk_command_t *e;
    int32_t args[LK_MAXARGS];
    call_t c;
    uint8_t sealed = 0, read_only, i;
    uint32_t echo = 0xFFFFFFFFUL; /* the CRC-32 register; complemented once the parsed request is complete */
    char ch;
    line[len] = 0;
    while (p < end && is_ws(*p)) p++;
    while (end > p && is_ws(end[-1])) end--;
    if (p == end) return;
    if (*p == '$') p++;
    for (r = end; r > p;) {
        if (*--r == '*') { star = r; break; }
    }
    if (star) {
        uint32_t v = 0;
        for (i = 1; i <= 8; i++) {
            uint8_t h = end - star != 9 ? 0xFF : hexval(star[i]);
            if (h > 15) { err_msg(-1, LK_E_BADCHK, LK_P("malformed")); return; }
            v = (v << 4) | h;
        }
        if (v != lk->star_crc) { /* computed byte by byte as the line came in (lk_rx), while the wire was busy */
            err_msg(-1, LK_E_BADCHK, LK_P("mismatch")); return;
        }
        end = star;
        sealed = 1;
    }
    *end = 0;
    c.seq = -1;
    c.a = args;
    c.argc = 0;
    cmd = next_token(&p);
    if (cmd && cmd[0] == '#') {
        int32_t s;
        const char *d = cmd + 1;
        uint8_t nd = 0;
        while (d[nd] >= '0' && d[nd] <= '9') nd++;
        if (nd < 1 || nd > 5 || d[nd] || !parse_int(d, &s) || s > 65535) {
            err_msg(-1, LK_E_SYNTAX, LK_P("seq")); return;
        }
        c.seq = s;
        cmd = next_token(&p);
    }
    if (!cmd) { err_msg(c.seq, LK_E_SYNTAX, LK_P("command")); return; }
    e = find_command(cmd);
    if (!e) { err_msg(c.seq, LK_E_UNKNOWN, 0); return; }
    read_only = (uint8_t)pgm_byte(&e->read_only);
    if (!read_only && (!sealed || c.seq < 0)) {
        err_msg(-1, LK_E_BADCHK, LK_P("unsealed")); return;
    }
    c.name = name = e->name;
    /* echo: CRC of what was parsed, "NAME a0 a1 ..." with the integers written canonically */
    while ((ch = LK_RD(name++)) != 0) echo = crc_step(echo, (uint8_t)ch);
    while ((tok = next_token(&p)) != 0) {
        if (c.argc >= LK_MAXARGS) { err_msg(c.seq, LK_E_SYNTAX, s_arguments); return; }
        if (!parse_int(tok, &args[c.argc])) { c.argc = 0xFF; break; } /* reported by dispatch */
        c.argc++;
        echo = crc_canonical(crc_step(echo, ' '), tok);
    }
    echo = ~echo;
    g_field = LK_NO_FIELD;
    if (!read_only && c.argc != 0xFF) { /* a malformed number is ERR 2 SYNTAX arguments (dispatch), whatever the seq */
        lk_seen_t *r;
        g_echo = echo; g_echo_on = 1;
        for (r = lk->seen; r < lk->seen + lk->seen_n; r++)
            if (r->seq == (uint16_t)c.seq && r->echo == echo) { replay(lk, e, &c, r->v); goto accepted; }
        /* stale: not newer than the newest accepted #seq (modulo 2^16, the 32767 ids after it are newer) and not
           a remembered repeat: a late copy of an old request, never run */
        if (lk->window && (uint16_t)((uint16_t)c.seq - lk->last_seq - 1u) >= 0x7FFFu) {
            err_begin(c.seq, LK_E_STALE); out_p(LK_P(" after #")); out_u(lk->last_seq); out_end();
            g_echo_on = 0;
            return;
        }
    }
    if (dispatch(lk, e, &c)) {
        if (g_echo_on) {
            lk_seen_t *r = &lk->seen[lk->seen_w];
            lk->last_seq = r->seq = (uint16_t)c.seq;
            r->echo = echo; r->v = g_field;
            lk->seen_w = (uint8_t)((lk->seen_w + 1) % LK_SEEN);
            if (lk->seen_n < LK_SEEN) lk->seen_n++;
            lk->window = 1;
        }
accepted:
        lk->last_accept_ms = lk->now_ms;
    }
    g_echo_on = 0;
}

void lk_rx(lk_t *lk, uint8_t b, uint32_t now_ms) {
    lk->now_ms = now_ms;
    if (b == '\r' || b == '\n') {
        if (lk->overflow) {
            lk->flags |= LK_F_INPUT_LOST;
            err_msg(-1, LK_E_TOOLONG, 0);
        } else if (lk->badchar) {
            err_msg(-1, LK_E_SYNTAX, LK_P("character"));
        } else {
            exec_line(lk);
        }
        lk->len = 0; lk->overflow = 0; lk->badchar = 0; lk->body = 0; lk->rx_crc = 0;
        return;
    }
    if (lk->overflow) return;
    if (lk->len >= LK_MAXLINE) { lk->overflow = 1; return; }
    if (!(b == '\t' || (b >= 0x20 && b <= 0x7E))) lk->badchar = 1;
    lk->line[lk->len++] = (char)b;
    /* the checksum covers the bytes after leading blanks and an optional '$' up to the last '*' (docs/protocol.md
       2.1): kept up to date here, so that a line's CRC is ready when its end arrives */
    if (!lk->body) {
        if (is_ws((char)b)) return;
        lk->body = 1;
        if (b == '$') return;
    }
    if (b == '*') lk->star_crc = lk->rx_crc;
    lk->rx_crc = ~crc_step(~lk->rx_crc, b);
}
