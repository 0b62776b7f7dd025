/* libFuzzer target: arbitrary bytes into the firmware core's receiver, interleaved with servo
 * frames and polls driven by the input. Invariants checked after every input (abort on failure):
 *   - every board line is <= LK_MAXLINE bytes and ends with a correct *HHHHHHHH CRC-32 and CR LF;
 *   - no unsealed state-changing line is ever acknowledged (OK without #seq and p= echo);
 *   - every commanded joint position lies within its limits and the servo range;
 *   - every pulse width lies within 400..2600 us.
 * Build: make -C firmware tests; run: firmware/build/fuzz_parser -runs=N (or -max_total_time=S). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hw_stub.h"

static lk_t lk;
static int booted;
static uint32_t frame, now_ms;

static void check_output(void) {
    const char *p = stub_out;
    while (*p) {
        const char *eol = strstr(p, "\r\n");
        if (!eol) {
            if (stub_out_len - (size_t)(p - stub_out) > LK_MAXLINE) abort();
            return; /* partial line at the end of the capture buffer */
        }
        unsigned hh;
        if (eol - p < 9 || eol - p > LK_MAXLINE || eol[-9] != '*' || strspn(eol - 8, "0123456789ABCDEF") < 8) abort();
        if (sscanf(eol - 8, "%8X", &hh) != 1 || hh != lk_crc32((const uint8_t *)p, (uint16_t)(eol - 9 - p))) abort();
        if (!strncmp(p, "OK ", 3)) {
            /* the command name follows "OK " or "OK #seq " */
            const char *name = p[3] == '#' ? strchr(p + 3, ' ') + 1 : p + 3;
            const char *after = strchr(name, ' ');
            if (strncmp(name, "HELLO", 5) && strncmp(name, "PING", 4) && strncmp(name, "STATUS", 6) &&
                strncmp(name, "READ", 4)) {
                /* a state-changing command was accepted: it must have been sealed (#seq echoed, p= echo) */
                if (p[3] != '#' || !after || after > eol || strncmp(after + 1, "p=", 2)) abort();
            }
        }
        p = eol + 2;
    }
}

static void check_state(void) {
    for (int j = 0; j < LK_JOINTS; j++) {
        const lk_cal_t *k = &lk.cal[j];
        int32_t servo = k->zero + k->dir * lk.q[j];
        if (lk.q[j] < k->lo || lk.q[j] > k->hi || servo < 0 || servo > LK_SERVO_FULL) abort();
    }
    for (int c = 0; c < LK_CHANNELS; c++)
        if (stub_pulses[c] < 800 || stub_pulses[c] > 5200) abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (!booted) {
        memset(stub_eeprom, 0xFF, sizeof stub_eeprom);
        lk_init(&lk, LK_RESET_POWER, 0, 0);
        booted = 1;
    }
    stub_clear();
    for (size_t i = 0; i < size; i++) {
        uint8_t b = data[i];
        if (b == 0x01 && i + 1 < size) { /* control byte: advance the clock by data[i+1] frames */
            uint8_t n = data[++i];
            for (uint8_t k = 0; k < n; k++) {
                frame++;
                now_ms += LK_FRAME_MS;
                lk_frame(&lk, frame + 1);
                lk_poll(&lk, now_ms, now_ms * 1000u);
            }
            continue;
        }
        if (b == 0x02) { /* reboot (EEPROM kept) */
            lk_init(&lk, LK_RESET_EXTERNAL, now_ms, now_ms * 1000u);
            continue;
        }
        lk_rx(&lk, b, now_ms);
    }
    check_output();
    check_state();
    return 0;
}
