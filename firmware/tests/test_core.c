/* Host-built unit tests of the firmware core (labkit_core.c): parser, checksum, limits,
 * calibration math, segment evaluation, queue, timeout, stream, EEPROM image.
 * Built with -fsanitize=address,undefined by `make -C firmware tests`; run by tests/test_firmware.py.
 * Prints one line per failed check and "core tests: N checks, F failed"; exit status 1 on failure. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hw_stub.h"

static int checks, failed;
#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        checks++;                                                          \
        if (!(cond)) {                                                     \
            failed++;                                                      \
            printf("FAIL %s:%d: %s | ", __FILE__, __LINE__, #cond);       \
            printf(__VA_ARGS__);                                           \
            printf("\n");                                                  \
        }                                                                  \
    } while (0)

static lk_t lk;
static uint32_t now_ms;

/* every board line must end with *HHHHHHHH\r\n where HHHHHHHH is the CRC-32 of the bytes before '*' */
static int lines_valid(const char *out) {
    const char *p = out;
    while (*p) {
        const char *eol = strstr(p, "\r\n");
        unsigned hh;
        if (!eol || eol - p < 9 || eol - p > LK_MAXLINE || eol[-9] != '*' || strspn(eol - 8, "0123456789ABCDEF") < 8) return 0;
        if (sscanf(eol - 8, "%8X", &hh) != 1 || hh != lk_crc32((const uint8_t *)p, (uint16_t)(eol - 9 - p))) return 0;
        p = eol + 2;
    }
    return 1;
}

static const char *send_raw(const char *line) {
    stub_clear();
    for (const char *c = line; *c; c++) lk_rx(&lk, (uint8_t)*c, now_ms);
    lk_rx(&lk, '\n', now_ms);
    return stub_out;
}

/* "#<seq> <line> *CRC" in buf */
static const char *sealed(char *buf, size_t size, unsigned seq, const char *line) {
    int n = snprintf(buf, size, "#%u %s ", seq, line);
    snprintf(buf + n, size - (size_t)n, "*%08X", (unsigned)lk_crc32((const uint8_t *)buf, (uint16_t)n));
    return buf;
}

static int read_only(const char *line) {
    return !strncmp(line, "HELLO", 5) || !strncmp(line, "PING", 4) || !strncmp(line, "STATUS", 6) ||
           !strncmp(line, "READ", 4);
}

/* A state-changing command is sent sealed (#seq ... *CRC, a new seq each time: the board answers a repeated
   seq and echo without running it); its replies are shown without " #seq" and " p=HHHHHHHH" (after checking that
   they are valid lines), so the expectations below read like the commands. */
static unsigned send_seq;
static const char *send(const char *line) {
    char buf[256], tag[12];
    if (strlen(line) > 150 || strspn(line, " ") == strlen(line) || line[0] == '#' || line[0] == '$' || strchr(line, '*') || read_only(line)) return send_raw(line);
    send_seq = send_seq % 60000 + 1;
    send_raw(sealed(buf, sizeof buf, send_seq, line));
    if (!lines_valid(stub_out)) return stub_out;
    char norm[STUB_OUT_SIZE];
    size_t n = 0;
    int tl = snprintf(tag, sizeof tag, " #%u ", send_seq);
    for (const char *p = stub_out; *p;) {
        if (!strncmp(p, tag, (size_t)tl) && (p - stub_out == 2 || p - stub_out == 3)) { p += tl - 1; continue; }
        if (!strncmp(p, " p=", 3) && strlen(p) > 11) { p += 11; continue; }
        norm[n++] = *p++;
    }
    norm[n] = 0;
    memcpy(stub_out, norm, n + 1);
    stub_out_len = n;
    return stub_out;
}

static int starts(const char *s, const char *prefix) { return strncmp(s, prefix, strlen(prefix)) == 0; }

static void boot(void) {
    now_ms = 0;
    stub_clear();
    lk_init(&lk, LK_RESET_POWER, 0, 0);
    lk_frame(&lk, 0);
}

static void run_frames(uint32_t from, uint32_t to) {
    for (uint32_t f = from; f < to; f++) {
        now_ms = f * LK_FRAME_MS;
        lk_poll(&lk, now_ms, now_ms * 1000);
        lk_frame(&lk, f + 1);
    }
}

/* a MOVE (q..., dur) runs as a rest-to-rest cubic; run it to its end and rewind the frame clock to boot */
static void finish_move(void) {
    run_frames(0, 20);
    CHECK(lk.state == LK_IDLE && strstr(stub_out, "EV DONE ") != NULL, "a MOVE did not end in 400 ms: %s", stub_out);
    now_ms = 0;
    lk_poll(&lk, 0, 0);
    lk_frame(&lk, 0);
}

static void move_done(const char *line) {
    send(line);
    CHECK(starts(stub_out, "OK MOVE 5*") && lk.state == LK_RUN, "%s", stub_out);
    finish_move();
}

static void test_helpers(void) {
    CHECK(lk_crc32((const uint8_t *)"123456789", 9) == 0xCBF43926UL, "crc %08X", (unsigned)lk_crc32((const uint8_t *)"123456789", 9));
    CHECK(lk_crc32((const uint8_t *)"", 0) == 0, "crc of nothing %08X", (unsigned)lk_crc32((const uint8_t *)"", 0));
    int32_t c[4] = {4500, 0, 13500, -9000};
    CHECK(lk_poly(c, 3, 1L << 23) == 6750, "poly(0.5) = %d", (int)lk_poly(c, 3, 1L << 23));
    CHECK(lk_poly(c, 3, 1L << 24) == 9000 && lk_poly(c, 3, 0) == 4500, "poly(1), poly(0)");
    int32_t big[6] = {-10000000, 10000000, -10000000, 10000000, -10000000, 10000001};
    CHECK(lk_poly(big, 5, 1L << 24) == 1 && lk_poly(big, 5, 0) == -10000000, "exact ends of a large quintic");
    /* integer Horner against double precision at every millisecond of a 1 s quintic: within half a cdeg + rounding */
    int32_t q5[6] = {9000, 2500, 1563, 4375, -7188, 2750};
    int worst = 0;
    for (uint16_t el = 0; el <= 1000; el++) {
        double s = el / 1000.0, x = 0;
        for (int i = 5; i >= 0; i--) x = x * s + q5[i];
        double d = fabs(lk_poly(q5, 5, (int32_t)(((uint64_t)el << 24) / 1000)) - x); /* 1/2 rounding, < 1/4 Horner */
        if (d > 0.75) worst++;
    }
    CHECK(worst == 0, "%d quintic samples further than 3/4 cdeg from the exact value", worst);
    lk_cal_t k = {500, 2500, 0, 1, 0, 18000};
    uint16_t h = 0;
    CHECK(lk_pulse_for(&k, 9000, &h) && h == 3000, "9000 cdeg -> %u half-us", h);
    CHECK(lk_pulse_for(&k, 3000, &h) && h == 1667, "3000 cdeg -> %u half-us (833.3 us)", h);
    CHECK(!lk_pulse_for(&k, 18001, &h) && !lk_pulse_for(&k, -1, &h), "servo range");
    lk_cal_t r = {600, 2400, 18000, -1, 0, 17000};
    CHECK(lk_pulse_for(&r, 4500, &h) && h == 2 * 1950, "reversed: %u", h);
}

static void test_handshake_and_framing(void) {
    char buf[256];
    boot();
    CHECK(starts(stub_out, "READY labkit-arm 3 fw=" LK_FW_VERSION " proto=3 joints=3 reset=POWER eeprom=DEFAULTS*"), "%s", stub_out);
    CHECK(lines_valid(stub_out), "%s", stub_out);
    send("HELLO");
    CHECK(starts(stub_out, "OK HELLO labkit-arm fw=" LK_FW_VERSION " proto=3 joints=3 channels=4 queue="), "%s", stub_out);
    CHECK(strstr(stub_out, "maxline=164*") != NULL && lines_valid(stub_out), "%s", stub_out);
    send("#7 PING*8983EB3B");
    CHECK(starts(stub_out, "OK #7 PING 0*"), "%s", stub_out);
    send("$#7 PING*8983eb3b");
    CHECK(starts(stub_out, "OK #7 PING"), "%s", stub_out);
    send("$#7 pinG*8983EB3B");
    CHECK(starts(stub_out, "ERR 1 BADCHK mismatch"), "a case flip changes the CRC: %s", stub_out);
    send("#7 PING*8983EB3C");
    CHECK(starts(stub_out, "ERR 1 BADCHK mismatch*"), "%s", stub_out);
    send("PING*24");
    CHECK(starts(stub_out, "ERR 1 BADCHK malformed"), "protocol-1 checksum: %s", stub_out);
    send("#7 PING*4824");
    CHECK(starts(stub_out, "ERR 1 BADCHK malformed"), "protocol-2 checksum (CRC-16): %s", stub_out);
    send("PING*8983EB3B4");
    CHECK(starts(stub_out, "ERR 1 BADCHK malformed"), "%s", stub_out);
    /* state-changing commands must be sealed; read-only ones may be typed */
    uint16_t before[4];
    memcpy(before, stub_pulses, sizeof before);
    const char *unsealed[] = {"MOVE 4500 9000 3000 250", "#5 MOVE 4500 9000 3000 250", "GRIP 1200", "STOP", "TIMEOUT 0",
                              "STREAM 10", "CAL 0", "SAVE", "DEFAULTS", "$MOVE 4500 9000 3000 250"};
    for (size_t i = 0; i < sizeof unsealed / sizeof *unsealed; i++) {
        send_raw(unsealed[i]);
        CHECK(starts(stub_out, "ERR 1 BADCHK unsealed*"), "%s -> %s", unsealed[i], stub_out);
    }
    /* sealed without #seq */
    {
        const char *body = "MOVE 4500 9000 3000 250 ";
        char line[64];
        snprintf(line, sizeof line, "%s*%08X", body, (unsigned)lk_crc32((const uint8_t *)body, (uint16_t)strlen(body)));
        send_raw(line);
        CHECK(starts(stub_out, "ERR 1 BADCHK unsealed*"), "%s", stub_out);
    }
    CHECK(memcmp(before, stub_pulses, sizeof before) == 0 && lk.timeout_ms == 500 && lk.stream_hz == 0, "unsealed ran");
    /* the line-split attack of issue 13: a byte turned into CR/LF runs neither half */
    sealed(buf, sizeof buf, 5, "MOVE 4500 9000 3000 250");
    for (size_t k = 1; k < strlen(buf); k++) {
        char split[256];
        memcpy(split, buf, strlen(buf) + 1);
        split[k] = (k & 1) ? '\n' : '\r';
        send_raw(split);
        CHECK(strstr(stub_out, "OK") == NULL, "split at %zu ran: %s", k, stub_out);
    }
    CHECK(memcmp(before, stub_pulses, sizeof before) == 0, "a split line moved something");
    /* the echo: CRC of what was parsed */
    send_raw(sealed(buf, sizeof buf, 9, "MOVE +4500 09000 3000 0250"));
    CHECK(starts(stub_out, "OK #9 MOVE p=9DCE02E2 5*"), "echo of the canonical MOVE 4500 9000 3000 250: %s", stub_out);
    send("STATUS");
    CHECK(strstr(stub_out, " last=9*") != NULL, "%s", stub_out);
    finish_move();
    send_raw(sealed(buf, sizeof buf, 10, "MOVE 4500 90000 3000 250"));
    CHECK(starts(stub_out, "ERR #10 6 LIMIT"), "%s", stub_out);
    send("STATUS");
    CHECK(strstr(stub_out, " last=9*") != NULL, "a rejected request is not last: %s", stub_out);
    send("   ");
    CHECK(stub_out_len == 0, "blank line answered: %s", stub_out);
    send("");
    CHECK(stub_out_len == 0, "empty line answered");
    send("FLY*4D");
    CHECK(starts(stub_out, "ERR 1 BADCHK"), "%s", stub_out);
    send("$");
    CHECK(starts(stub_out, "ERR 2 SYNTAX command"), "%s", stub_out);
    send("#65536 PING");
    CHECK(starts(stub_out, "ERR 2 SYNTAX seq*"), "%s", stub_out);
    send("#1 FLY\x01");
    CHECK(starts(stub_out, "ERR 2 SYNTAX character"), "%s", stub_out);
    send("#3 fly away");
    CHECK(starts(stub_out, "ERR #3 3 UNKNOWN*"), "%s", stub_out);
    char longline[400];
    memset(longline, 'A', sizeof longline - 1);
    longline[sizeof longline - 1] = 0;
    send(longline);
    CHECK(starts(stub_out, "ERR 4 TOOLONG"), "%s", stub_out);
    longline[LK_MAXLINE] = 0; /* exactly maxline: accepted as a line (unknown command) */
    send(longline);
    CHECK(starts(stub_out, "ERR 3 UNKNOWN*"), "%s", stub_out);
    send("PING");
    CHECK(starts(stub_out, "OK PING"), "recovers after long lines: %s", stub_out);
    /* CR LF and lone CR both end lines */
    stub_clear();
    const char *two = "PING\r\nPING\rPING\n";
    for (const char *c = two; *c; c++) lk_rx(&lk, (uint8_t)*c, 0);
    int n = 0;
    for (const char *p = stub_out; (p = strstr(p, "OK PING")) != NULL; p++) n++;
    CHECK(n == 3, "3 replies expected, got %d: %s", n, stub_out);
    CHECK(lines_valid(stub_out), "%s", stub_out);
}

static void test_moves_and_limits(void) {
    boot();
    CHECK(stub_pulses[0] == 3000 && stub_pulses[3] == 3000, "boot pulses %u %u", stub_pulses[0], stub_pulses[3]);
    send("MOVE 4500 9000 3000 250");
    CHECK(starts(stub_out, "OK MOVE 5*") && lk.state == LK_RUN && lk.q[0] == 9000, "starts as a trajectory: %s", stub_out);
    run_frames(0, 7); /* t = 140 ms: 120 ms into the 250 ms cubic */
    CHECK(lk.q[0] > 6750 && lk.q[0] < 9000 - 1, "half way down: %d", (int)lk.q[0]);
    run_frames(7, 20);
    CHECK(lk.state == LK_IDLE && lk.done == 1, "state %d done %u", lk.state, (unsigned)lk.done);
    CHECK(stub_pulses[0] == 2000 && stub_pulses[1] == 3000 && stub_pulses[2] == 1667, "pulses %u %u %u",
          stub_pulses[0], stub_pulses[1], stub_pulses[2]);
    uint16_t before[4];
    memcpy(before, stub_pulses, sizeof before);
    const char *bad[] = {"MOVE 4500 19000 3000 250", "MOVE -1 0 0 250", "MOVE 1 2 3", "MOVE 1 2 3 4 5", "MOVE 1.5 2 3 250",
                         "MOVE 2147483648 0 0 250", "MOVE -2147483649 0 0 250", "MOVE + 0 0 250", "MOVE 0x10 0 0 250",
                         "MOVE 4500 9000 3000 0", "MOVE 4500 9000 3000 60001", "MOVE 9000 9000 3000 5", "MOVE 4500 9000 3000",
                         "GRIP 2501", "GRIP 499", "CAL 4", "CAL 0 500 500 0 1 0 18000", "CAL 0 500 2500 0 1 10000 18000"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        send(bad[i]);
        CHECK(starts(stub_out, "ERR "), "%s -> %s", bad[i], stub_out);
        CHECK(memcmp(before, stub_pulses, sizeof before) == 0, "%s moved something", bad[i]);
    }
    send("MOVE 4500 19000 3000 250");
    CHECK(starts(stub_out, "ERR 6 LIMIT joint 1*"), "%s", stub_out);
    send("MOVE 4500 9000 3000 0");
    CHECK(starts(stub_out, "ERR 5 RANGE duration*"), "%s", stub_out);
    /* issue 13: a MOVE faster than the speed limit (45 deg in 50 ms: 1350 deg/s > 600) is refused, nothing moves */
    send("MOVE 9000 9000 3000 50");
    CHECK(starts(stub_out, "ERR 11 SPEED joint 0*") && lk.state == LK_IDLE && lk.q_count == 0 && lk.q[0] == 4500,
          "%s", stub_out);
    CHECK(memcmp(before, stub_pulses, sizeof before) == 0, "an out-of-speed MOVE moved something");
    send("MOVE 9000 9000 3000 113"); /* 1.5 * 4500 / 0.113 = 59735 cdeg/s <= 60000 */
    CHECK(starts(stub_out, "OK MOVE"), "%s", stub_out);
    send("MOVE 9000 9000 3000 113");
    CHECK(starts(stub_out, "ERR 8 BUSY"), "%s", stub_out);
    send("STOP");
    CHECK(starts(stub_out, "OK STOP 4500 9000 3000*"), "%s", stub_out);
    send("GRIP 1900");
    CHECK(starts(stub_out, "OK GRIP 1900") && stub_pulses[3] == 3800, "%s", stub_out);
    send("STATUS");
    CHECK(starts(stub_out, "OK STATUS state=IDLE q=4500,9000,3000 grip=1900 queue=0 free="), "%s", stub_out);
}

static void test_segments(void) {
    boot();
    send("TIMEOUT 0");
    move_done("MOVE 4500 9000 3000 250");
    run_frames(0, 5);
    /* frame clock: the next frame to program is #6, starting at 120 ms */
    send("SEG 1000 3 4500 0 13500 -9000 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "OK SEG "), "%s", stub_out);
    int32_t max_err = 0;
    for (uint32_t f = 5; f < 5 + 50; f++) {
        lk_frame(&lk, f + 1);
        double s = ((f + 1) * 20 - 120) / 1000.0;
        int32_t want = (int32_t)floor(4500 + 13500 * s * s - 9000 * s * s * s + 0.5);
        int32_t e = labs(lk.q[0] - want);
        if (e > max_err) max_err = e;
    }
    CHECK(max_err <= 1, "cubic samples deviate by %d cdeg", max_err);
    stub_clear();
    lk_frame(&lk, 56); /* t = 1120 ms: segment over */
    CHECK(lk.q[0] == 9000 && lk.state == LK_IDLE, "end q %d state %d", lk.q[0], lk.state);
    CHECK(starts(stub_out, "EV DONE 2*"), "the MOVE and the segment: %s", stub_out);

    /* queue overflow, continuity, busy, stop */
    char line[200];
    snprintf(line, sizeof line, "SEG 500 5 9000 0 0 0 0 0 9000 0 0 0 0 0 3000 0 0 0 0 0");
    for (int i = 0; i < LK_QUEUE; i++) {
        send(line);
        char want[32];
        snprintf(want, sizeof want, "OK SEG %d*", LK_QUEUE - 1 - i);
        CHECK(starts(stub_out, want), "%s", stub_out);
    }
    send(line);
    CHECK(starts(stub_out, "ERR 7 QFULL"), "%s", stub_out);
    send("MOVE 9000 9000 3000 250");
    CHECK(starts(stub_out, "ERR 8 BUSY"), "%s", stub_out);
    send("STOP");
    CHECK(starts(stub_out, "OK STOP 9000 9000 3000*") && lk.q_count == 0 && lk.state == LK_IDLE, "%s", stub_out);
    send("SEG 500 3 9050 0 0 0 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "OK SEG"), "50 cdeg jump allowed: %s", stub_out);
    send("STOP");
    send("SEG 500 3 9051 0 0 0 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "ERR 9 DISCONT joint 0"), "%s", stub_out);
    send("SEG 500 3 9000 0 81000 -81000 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "ERR 6 LIMIT joint 0*"), "overshoot: %s", stub_out);
    send("SEG 60001 3 9000 0 0 0 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "ERR 5 RANGE"), "%s", stub_out);
}

static void test_speed_limits(void) {
    boot();
    send("TIMEOUT 0");
    move_done("MOVE 4500 9000 3000 250");
    send("LIMITS 0");
    CHECK(starts(stub_out, "OK LIMITS 0 60000 0*"), "factory limits: %s", stub_out);
    send("LIMITS 0 30000 150000");
    CHECK(starts(stub_out, "OK LIMITS 0 30000 150000*"), "%s", stub_out);
    send("LIMITS 3 1 1");
    CHECK(starts(stub_out, "ERR 5 RANGE joint"), "%s", stub_out);
    send("LIMITS 0 -1 0");
    CHECK(starts(stub_out, "ERR 5 RANGE limits"), "%s", stub_out);
    /* issue 13: a 500 ms segment whose duration lost "00" (45 -> 90 deg in 5 ms) */
    uint16_t before[4];
    memcpy(before, stub_pulses, sizeof before);
    send("SEG 5 3 4500 0 13500 -9000 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "ERR 11 SPEED joint 0*") && lk.q_count == 0 && lk.state == LK_IDLE, "%s", stub_out);
    /* 45 deg in 0.25 s: peak 270 deg/s < 300, but 4320 deg/s^2 > 1500 */
    send("SEG 250 3 4500 0 13500 -9000 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "ERR 11 SPEED joint 0*"), "acceleration: %s", stub_out);
    send("SEG 1000 3 4500 0 13500 -9000 9000 0 0 0 3000 0 0 0");
    CHECK(starts(stub_out, "OK SEG"), "67.5 deg/s, 270 deg/s^2: %s", stub_out);
    run_frames(0, 2);
    send("LIMITS 1 0 0");
    CHECK(starts(stub_out, "ERR 8 BUSY"), "%s", stub_out);
    send("STOP");
    CHECK(memcmp(before, stub_pulses, sizeof before) != 0, "the good segment moved");
    send("LIMITS 1 0 0");
    send("SAVE");
    CHECK(starts(stub_out, "OK SAVE 78*"), "%s", stub_out);
    boot();
    send("LIMITS 0");
    CHECK(starts(stub_out, "OK LIMITS 0 30000 150000*"), "limits survive a reset: %s", stub_out);
    send("LIMITS 1");
    CHECK(starts(stub_out, "OK LIMITS 1 0 0*"), "%s", stub_out);
    int32_t c[4] = {0, 0, 3000, -2000}; /* 10 deg rest-to-rest: |dq/ds| peaks at 1500 (s = 1/2), |d2q/ds2| at 6000 */
    int32_t scratch[LK_SCRATCH];
    /* over 1 s: |dq/ds| <= vmax, |d2q/ds2| <= amax exactly at the peaks */
    CHECK(lk_check(c, 3, 1, 0, 0, 1500, 1000, scratch) && !lk_check(c, 3, 1, 0, 0, 1499, 1000, scratch) &&
          lk_check(c, 3, 2, 0, 0, 6000, 1000000, scratch) && !lk_check(c, 3, 2, 0, 0, 5999, 1000000, scratch), "speed peaks");
    /* issue 13: a peak between the samples s = k/16 of the old check (2.1.0): the samples reach 5400, the peak
       at s = 17/32 5418.75 cdeg (90 ms at 600 deg/s allow 5400): refused now, and so on the wire */
    int32_t between[4] = {9000, 0, 10200, -6400};
    CHECK(!lk_check(between, 3, 1, 0, 0, 60000, 90, scratch) && lk_check(between, 3, 1, 0, 0, 60210, 90, scratch),
          "a speed peak between the old samples");
    send("STOP");
    send("LIMITS 1 60000 0");
    memcpy(before, stub_pulses, sizeof before);
    send("SEG 90 3 9000 0 0 0 9000 0 10200 -6400 9000 0 0 0");
    CHECK(starts(stub_out, "ERR 11 SPEED joint 1*") && lk.q_count == 0 && lk.state == LK_IDLE && lk.q[1] == 9000,
          "between the samples: %s", stub_out);
    CHECK(memcmp(before, stub_pulses, sizeof before) == 0, "a refused SEG moved something");
    memset(stub_eeprom, 0xFF, sizeof stub_eeprom);
}

static void test_timeout_and_stream(void) {
    boot();
    send("TIMEOUT 100");
    CHECK(starts(stub_out, "OK TIMEOUT 100*"), "%s", stub_out);
    send("SEG 1000 3 9000 0 9000 -6000 9000 0 0 0 9000 0 0 0");
    CHECK(starts(stub_out, "OK SEG"), "%s", stub_out);
    stub_clear();
    run_frames(1, 5); /* 80 ms: still running */
    CHECK(lk.state == LK_RUN, "state %d", lk.state);
    run_frames(5, 10); /* 180 ms > 100 ms of silence */
    CHECK(lk.state == LK_HOLD && (lk.flags & LK_F_TIMEOUT_HOLD), "state %d flags %x", lk.state, lk.flags);
    CHECK(strstr(stub_out, "EV HOLD ") != NULL, "%s", stub_out);
    int32_t held = lk.q[0];
    run_frames(10, 20);
    CHECK(lk.q[0] == held, "moved after hold");

    boot();
    stub_adc[0] = 100; stub_adc[1] = 200; stub_adc[2] = 300; stub_adc[5] = 1023;
    send("READ");
    CHECK(starts(stub_out, "OK READ 100 200 300 1023*"), "%s", stub_out);
    send("STREAM 201");
    CHECK(starts(stub_out, "ERR 5 RANGE"), "%s", stub_out);
    send("STREAM 100");
    stub_clear();
    for (uint32_t us = 0; us < 1000000; us += 1000) lk_poll(&lk, us / 1000, 5000000 + us);
    int frames = 0;
    for (const char *p = stub_out; (p = strstr(p, "FB ")) != NULL; p++) frames++;
    CHECK(frames == 100, "100 frames in 1 s at 100 Hz, got %d", frames);
    CHECK(starts(stub_out, "FB 0 0 100 200 300 1023*"), "%s", stub_out);
    CHECK(strstr(stub_out, "FB 99 990 ") != NULL && lines_valid(stub_out), "counter");
    /* a busy board skips periods: the counter jumps so the host sees the gap */
    stub_clear();
    lk_poll(&lk, 1050, 5000000 + 1050000);
    CHECK(starts(stub_out, "FB 100 "), "%s", stub_out);
    stub_clear();
    lk_poll(&lk, 1061, 5000000 + 1061000);
    CHECK(starts(stub_out, "FB 106 "), "%s", stub_out);
}

static void test_eeprom(void) {
    memset(stub_eeprom, 0xFF, sizeof stub_eeprom);
    boot();
    CHECK(lk.flags & LK_F_EEPROM_DEFAULTS, "blank EEPROM -> defaults");
    send("CAL 2 600 2400 18000 -1 0 17000");
    CHECK(starts(stub_out, "OK CAL 2 600 2400 18000 -1 0 17000*"), "%s", stub_out);
    send("TIMEOUT 1500");
    send("SAVE");
    CHECK(starts(stub_out, "OK SAVE 78*"), "%s", stub_out);
    /* the image is sealed with the lines' CRC-32, little-endian; the virtual board's image of the same settings
       (labkit.arm.board eeprom_image) ends with the same four bytes */
    {
        uint32_t crc = lk_crc32(stub_eeprom, 74);
        CHECK(stub_eeprom[2] == 3 && stub_eeprom[74] == (uint8_t)crc && stub_eeprom[75] == (uint8_t)(crc >> 8) &&
              stub_eeprom[76] == (uint8_t)(crc >> 16) && stub_eeprom[77] == (uint8_t)(crc >> 24), "image CRC");
        CHECK(crc == 0xA63237F5UL, "image CRC %08X, the virtual board's is A63237F5", (unsigned)crc);
    }
    boot();
    CHECK(!(lk.flags & LK_F_EEPROM_DEFAULTS) && strstr(stub_out, "eeprom=OK"), "%s", stub_out);
    CHECK(lk.cal[2].pmin == 600 && lk.cal[2].dir == -1 && lk.cal[2].hi == 17000 && lk.timeout_ms == 1500, "loaded");
    CHECK(lk.q[2] == 8500 && stub_pulses[2] == 3100, "boot at mid-limits: q %d pulse %u", lk.q[2], stub_pulses[2]);
    stub_eeprom[10] ^= 1; /* corrupt one byte: CRC fails */
    boot();
    CHECK((lk.flags & LK_F_EEPROM_DEFAULTS) && lk.cal[2].pmin == 500 && lk.timeout_ms == 500, "corrupt -> defaults");
    stub_ee_fail = 1;
    send("SAVE");
    CHECK(starts(stub_out, "ERR 10 EEPROM"), "%s", stub_out);
    stub_ee_fail = 0;
}

/* ---- the motion checks against dense sampling of many random polynomials (docs/protocol.md 4.3) ---- */
static uint32_t rng_state = 12345u;
static uint32_t rnd(void) { rng_state = rng_state * 1664525u + 1013904223u; return rng_state >> 8; } /* 24 bits */
static int32_t rnd_in(int32_t lo, int32_t hi) { return lo + (int32_t)(((uint64_t)rnd() * (uint64_t)(hi - lo + 1)) >> 24); }

/* extremes of q^(kind) on 0 <= s <= 1 from 20001 samples (and the ends) */
static void dense(const int32_t *c, uint8_t order, uint8_t kind, double *lo, double *hi) {
    *lo = 1e300; *hi = -1e300;
    for (int k = 0; k <= 20000; k++) {
        double s = k / 20000.0, v = 0;
        for (int i = order; i >= kind; i--) {
            double f = 1;
            for (int t = 0; t < kind; t++) f *= i - t;
            v = v * s + f * c[i];
        }
        if (v < *lo) *lo = v;
        if (v > *hi) *hi = v;
    }
}

static void test_motion_checks_against_dense_sampling(void) {
    int32_t scratch[LK_SCRATCH], c[6];
    int unsafe = 0, strict = 0, accepted = 0, refused = 0, undecided_near = 0, n = 0;
    for (int trial = 0; trial < 40000; trial++) {
        uint8_t order = (rnd() & 1) ? 3 : 5, kind = (uint8_t)(rnd() % 3);
        int32_t mag = (int32_t[]){100, 3000, 30000, 1000000, 10000000}[rnd() % 5];
        for (int i = 0; i <= order; i++) c[i] = rnd_in(-mag, mag);
        if (rnd() % 4 == 0) { /* rest-to-rest or through-the-middle shapes, like real trajectories */
            int32_t d = rnd_in(-9000, 9000);
            c[0] = rnd_in(0, 18000); c[1] = 0;
            if (order == 3) { c[2] = 3 * d; c[3] = -2 * d; }
            else { c[2] = 0; c[3] = 10 * d; c[4] = -15 * d; c[5] = 6 * d; }
            if (rnd() & 1) c[1] = rnd_in(-mag, mag);
        }
        double lo, hi, f = 0.9 + 0.2 * (rnd() / 16777216.0); /* the limit: 0.9 .. 1.1 of the extreme */
        dense(c, order, kind, &lo, &hi);
        uint8_t ok;
        double margin; /* how far inside (> 0) or outside (< 0) the limit the dense extremes are, relative */
        if (kind == 0) {
            double mid = (lo + hi) / 2, half = (hi - lo) / 2 * f + 1;
            int32_t a = (int32_t)floor(mid - half), b = (int32_t)ceil(mid + half);
            if (a < -32000000 || b > 32000000) continue;
            ok = lk_check(c, order, 0, a, b, 0, 0, scratch);
            margin = fmin(lo - a, b - hi) / (b - a + 1e-9);
            if (ok && (lo < a || hi > b)) unsafe++;
        } else {
            double peak = fmax(fabs(lo), fabs(hi));
            uint32_t dur = (uint32_t)rnd_in(1, 60000), y = kind == 1 ? dur : dur * dur;
            double scale = kind == 1 ? 1000.0 : 1000000.0, want = peak * f * scale / y;
            if (want < 1 || want > (kind == 1 ? 1e6 : 1e8)) continue; /* LIMITS accepts up to 10^6 and 10^8 */
            uint32_t x = (uint32_t)want;
            double limit = (double)x * y / scale;
            ok = lk_check(c, order, kind, 0, 0, x, y, scratch);
            margin = (limit - peak) / (limit + 1e-9);
            if (ok && peak > limit * (1 + 1e-12)) unsafe++;
        }
        n++;
        ok ? accepted++ : refused++;
        if (!ok && margin > 1e-3) strict++;           /* clearly inside but refused */
        if (!ok && margin > 0) undecided_near++;
    }
    CHECK(unsafe == 0, "%d of %d accepted segments exceed the limit between samples", unsafe, n);
    CHECK(strict == 0, "%d of %d segments more than 0.1%% inside their limit refused", strict, n);
    CHECK(n > 20000 && accepted > n / 4 && refused > n / 4, "cases %d, accepted %d, refused %d", n, accepted, refused);
    printf("motion checks: %d random polynomials, %d accepted, %d refused (%d of them within 0.1%% inside)\n", n,
           accepted, refused, undecided_near);
}

/* a repeated sealed request (same #seq, same echo) among the last LK_SEEN accepted ones is answered with its reply
   and not run; a rejected one runs when repeated; one with the same seq but other content, or older than the window,
   is stale: ERR 12, not run (issue 27); HELLO opens a new session */
static void test_repeats(void) {
    char buf[256], first[STUB_OUT_SIZE];
    boot();
    send_raw(sealed(buf, sizeof buf, 777, "SEG 500 3 9000 0 0 0 9000 0 0 0 9000 0 0 0"));
    CHECK(starts(stub_out, "OK #777 SEG p=") && lk.q_count == 1, "%s", stub_out);
    strcpy(first, stub_out);
    send_raw(buf);
    CHECK(!strcmp(stub_out, first) && lk.q_count == 1, "repeat ran or answered otherwise: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 777, "SEG 500 3 9000 0 0 0 9000 0 0 0 9000 0 0 1"));
    CHECK(starts(stub_out, "ERR #777 12 STALE after #777*") && lk.q_count == 1, "same seq, other content: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 778, "STOP"));
    strcpy(first, stub_out);
    CHECK(starts(stub_out, "OK #778 STOP p=") && lk.q_count == 0, "%s", stub_out);
    send_raw(buf);
    CHECK(!strcmp(stub_out, first), "STOP repeat: %s vs %s", stub_out, first);
    send_raw(sealed(buf, sizeof buf, 779, "CAL 3 700 2300 0 1 0 18000"));
    strcpy(first, stub_out);
    send_raw(buf);
    CHECK(!strcmp(stub_out, first) && starts(first, "OK #779 CAL p="), "CAL repeat: %s vs %s", stub_out, first);
    send_raw(sealed(buf, sizeof buf, 780, "LIMITS 1 30000 0"));
    strcpy(first, stub_out);
    send_raw(buf);
    CHECK(!strcmp(stub_out, first) && starts(first, "OK #780 LIMITS p="), "LIMITS repeat: %s vs %s", stub_out, first);
    send_raw(sealed(buf, sizeof buf, 781, "GRIP 5000")); /* rejected: not remembered, runs again when repeated */
    CHECK(starts(stub_out, "ERR #781 5 RANGE"), "%s", stub_out);
    send_raw(buf);
    CHECK(starts(stub_out, "ERR #781 5 RANGE"), "%s", stub_out);
    /* a repeat of a request older than the last LK_SEEN accepted ones is no longer recognised: stale, never run,
       however many newer requests came (a #5 MOVE after 10 newer ones) */
    send_raw(sealed(buf, sizeof buf, 782, "SEG 500 3 9000 0 0 0 9000 0 0 0 9000 0 0 0"));
    CHECK(lk.q_count == 1, "%s", stub_out);
    for (unsigned k = 0; k < 10; k++) {
        char b2[64];
        send_raw(sealed(b2, sizeof b2, 800 + k, "GRIP 1500"));
        CHECK(starts(stub_out, "OK #"), "%s", stub_out);
    }
    send_raw(buf);
    CHECK(starts(stub_out, "ERR #782 12 STALE after #809*") && lk.q_count == 1, "beyond the window: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 810, "STOP"));
    boot();
    send_raw(sealed(buf, sizeof buf, 5, "MOVE 9000 9000 9000 60000"));
    CHECK(starts(stub_out, "OK #5 MOVE p=") && lk.q_count == 1, "%s", stub_out);
    send_raw(sealed(buf, sizeof buf, 6, "STOP"));
    for (unsigned k = 7; k < 17; k++) {
        char b2[64];
        send_raw(sealed(b2, sizeof b2, k, "GRIP 1500"));
    }
    send_raw(sealed(buf, sizeof buf, 5, "MOVE 9000 9000 9000 60000"));
    CHECK(starts(stub_out, "ERR #5 12 STALE after #16*") && lk.q_count == 0 && lk.state == LK_IDLE, "stale MOVE: %s",
          stub_out);
    /* ids count modulo 2^16: the 32767 after the newest are newer */
    send_raw(sealed(buf, sizeof buf, 65535, "GRIP 1500"));
    CHECK(starts(stub_out, "ERR #65535 12 STALE"), "65535 after 16 is 32767 + 1 behind: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 32783, "GRIP 1500"));
    CHECK(starts(stub_out, "OK #32783 GRIP"), "16 + 32767: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 65535, "GRIP 1500"));
    CHECK(starts(stub_out, "OK #65535 GRIP"), "%s", stub_out);
    send_raw(sealed(buf, sizeof buf, 1, "GRIP 1501"));
    CHECK(starts(stub_out, "OK #1 GRIP"), "wrap-around: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 0, "GRIP 1502"));
    CHECK(starts(stub_out, "ERR #0 12 STALE after #1*"), "%s", stub_out);
    /* HELLO opens a new session: the window and the remembered requests are forgotten */
    send_raw("HELLO");
    send_raw(sealed(buf, sizeof buf, 1, "GRIP 1600"));
    CHECK(starts(stub_out, "OK #1 GRIP") && lk.grip_us == 1600, "after HELLO: %s", stub_out);
    send_raw(sealed(buf, sizeof buf, 1, "GRIP 1600"));
    CHECK(starts(stub_out, "OK #1 GRIP") && lk.grip_us == 1600, "repeat after HELLO: %s", stub_out);
}

int main(void) {
    test_helpers();
    test_handshake_and_framing();
    test_moves_and_limits();
    test_segments();
    test_speed_limits();
    test_motion_checks_against_dense_sampling();
    test_timeout_and_stream();
    test_eeprom();
    test_repeats();
    printf("core tests: %d checks, %d failed\n", checks, failed);
    return failed ? 1 : 0;
}
