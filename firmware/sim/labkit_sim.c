/* labkit_sim: firmware-in-the-loop harness for the labkit arm firmware on simavr.
 *
 * usage: labkit_sim FIRMWARE.elf [--run] [--pace FACTOR]
 *
 * Loads the ELF into a simulated ATmega328P at 16 MHz (VCC = AVCC = AREF = 5000 mV), bridges
 * UART0 to a pseudo terminal and talks to its controller (labkit/firmware_sim.py) through a
 * line protocol on stdin/stdout. simavr's own messages go to stderr.
 *
 * stdout (harness -> controller), one event per line:
 *   PTY <path>                       pty of UART0 (printed once, first line)
 *   READY held|running               after start-up
 *   P <ch> <t_us> <width_us>         servo channel ch (pin D(2+ch)) finished a pulse whose width
 *                                    differs by > 0.45 us from the last one reported for that channel
 *   TICK <t_us> <w0> ... <w5>        tick (see `tick`): CPU paused until `go`
 *   WOKE <t_us>                      simulated time reached a `sleep` deadline
 *   TIME <t_us> | PULSES <t_us> <w0> ... <w5> | OK <cmd> | ERR <text>
 *   CRASH <state> <t_us>             the simulated CPU stopped (crashed/done)
 * stdin (controller -> harness):
 *   run | hold | reset | quit
 *   adc <pin 0-5> <millivolts>       analog input voltage
 *   pace <factor>                    0: free running; f > 0: simulated time = f x wall time
 *   tick <period_us>                 0: off; else stop every period, print TICK, wait for `go`
 *   go                               continue after a TICK
 *   sleep <us>                       print WOKE once `us` more simulated microseconds elapsed
 *   time | pulses                    query
 *   lockstep 0|1                     1: after each OK/ERR reply line and each WOKE, hold the CPU
 *                                    until the host sends bytes or a `sleep` (zero reaction time)
 *   stepped 0|1                      1: the CPU runs only inside `advance` grants (board-time host)
 *   advance <us> <bytes> <line 0|1>  (stepped) wait until <bytes> host bytes in total have been
 *                                    read from the pty, run for <us> simulated microseconds or, with
 *                                    line=1, until the board completed a line (whichever is first),
 *                                    write the board's bytes to the pty, then print
 *                                    HELD <t_us> <board bytes written to the pty in total>
 * Times are simulated microseconds since power-on (cycles / 16).
 *
 * Stepped mode makes the simulation a function of what the host sends and how long it waits in
 * board time only: a slow or descheduled host freezes simulated time instead of missing it (the
 * host's clock is the simulated one; see labkit/arm/_simavr_port.py). Bytes written by the host
 * reach the harness through the pty asynchronously, hence the byte count in `advance`; the count in
 * HELD tells the host how many board bytes are on their way through the pty. The harness does not use
 * simavr's uart_pty part (two threads, no locking); it bridges the UART to a pty itself.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/prctl.h>
#include <termios.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <simavr/avr_adc.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>

#define NCH 6
#define FIRST_PIN 2

static avr_t *avr;
/* UART0 <-> pty bridge, single-threaded (simavr's uart_pty part feeds the UART from a second
   thread without locking and wedges on bursts larger than its 512-byte FIFO) */
static int pty_master = -1, pty_slave = -1;
static char pty_name[128];
static avr_irq_t *uart_in_irq;
static int uart_xon = 1;
static uint8_t rx_buf[8192]; /* host -> AVR, not yet accepted by the UART */
static size_t rx_head, rx_len;
static uint8_t tx_buf[65536]; /* AVR -> host, not yet written to the pty */
static size_t tx_len;
static unsigned long tx_dropped;
/* lockstep: after the board finishes a reply line (OK/ERR ...\n) hold the CPU until the host
   sends bytes or asks for simulated time (`sleep`): an immediately responding host */
static int lockstep, lock_wait, line_start = 1, line_is_reply;
/* stepped: simulated time advances only inside a grant (`advance`) */
static int stepped, granted, grant_lines, line_done;
static uint64_t grant_end_cycle;
static unsigned long long rx_total, tx_total; /* bytes read from / written to the pty master */
static FILE *ctl; /* control output (the real stdout) */
static int running;
static double pace; /* 0 = free */
static uint64_t tick_period_cycles, next_tick_cycle;
static uint64_t wake_cycle;
static int waking;
static uint64_t rise_cycle[NCH];
static double width_us[NCH];
static double wall_ref, sim_ref_us;
static uint32_t adc_mv[6];

static double now_wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}
static double sim_us(void) { return (double)avr->cycle * 1e6 / avr->frequency; }

static void say(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vfprintf(ctl, fmt, ap);
    va_end(ap);
    fputc('\n', ctl);
    fflush(ctl);
}

/* Host -> AVR bytes arrive at the line rate: one byte per 10 bit times (8N1 at 115200 baud),
   from a cycle timer, unless the UART's input FIFO is full (XOFF). */
#define CYCLES_PER_BYTE 1389 /* 16 MHz * 10 bits / 115200 baud */
static int feed_active;
static avr_cycle_count_t uart_feed_timer(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a; (void)param;
    if (rx_len && uart_xon) {
        uint8_t b = rx_buf[rx_head];
        rx_head = (rx_head + 1) % sizeof rx_buf;
        rx_len--;
        avr_raise_irq(uart_in_irq, b);
    }
    if (!rx_len) { feed_active = 0; return 0; }
    return when + CYCLES_PER_BYTE;
}
static void uart_feed(void) {
    if (rx_len && !feed_active) {
        feed_active = 1;
        avr_cycle_timer_register(avr, 1, uart_feed_timer, NULL);
    }
}
static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq; (void)value; (void)param;
    uart_xon = 1;
}
static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq; (void)value; (void)param;
    uart_xon = 0;
}
static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq; (void)param;
    if (tx_len < sizeof tx_buf) tx_buf[tx_len++] = (uint8_t)value;
    else tx_dropped++;
    if (line_start) line_is_reply = (value == 'O' || value == 'E') ? 2 : 0; /* OK / ERR (not EV) */
    else if (line_is_reply == 2) line_is_reply = (value == 'K' || value == 'R');
    line_start = (value == '\n');
    if (line_start) line_done = 1;
    if (line_start && line_is_reply && lockstep) lock_wait = 1;
}
/* move bytes between the pty and the buffers (non-blocking) */
static void pty_pump(void) {
    if (tx_len) {
        ssize_t w = write(pty_master, tx_buf, tx_len);
        if (w > 0) { memmove(tx_buf, tx_buf + w, tx_len - (size_t)w); tx_len -= (size_t)w; tx_total += (unsigned long long)w; }
    }
    while (rx_len < sizeof rx_buf) {
        uint8_t tmp[512];
        size_t room = sizeof rx_buf - rx_len, want = room < sizeof tmp ? room : sizeof tmp;
        ssize_t r = read(pty_master, tmp, want);
        if (r <= 0) break;
        lock_wait = 0;
        rx_total += (unsigned long long)r;
        for (ssize_t i = 0; i < r; i++) rx_buf[(rx_head + rx_len + (size_t)i) % sizeof rx_buf] = tmp[i];
        rx_len += (size_t)r;
    }
    uart_feed();
}

static int pty_open(void) {
    struct termios tio;
    if (openpty(&pty_master, &pty_slave, pty_name, NULL, NULL) < 0) return -1;
    tcgetattr(pty_master, &tio);
    cfmakeraw(&tio); /* no echo, no line discipline: a plain 8-bit wire */
    tcsetattr(pty_master, TCSANOW, &tio);
    fcntl(pty_master, F_SETFL, fcntl(pty_master, F_GETFL) | O_NONBLOCK);
    /* pty_slave stays open so that reads on the master do not fail before a host opens it */
    return 0;
}

static void uart_connect(void) {
    uint32_t f = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &f);
    f &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP); /* no usleep() on UCSR0A polls */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &f);
    uart_in_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out_hook, 0);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon_hook, 0);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff_hook, 0);
}

/* simavr's default sleep callback usleep()s through simulated sleep: free running would be tied
   to ~1x real time while the firmware idles. Pacing is done by this harness instead. */
static void no_wall_sleep(avr_t *a, avr_cycle_count_t how_long) { (void)a; (void)how_long; }

static void anchor_pace(void) {
    wall_ref = now_wall();
    sim_ref_us = sim_us();
}

static void pin_changed(struct avr_irq_t *irq, uint32_t value, void *param) {
    int ch = (int)(intptr_t)param;
    (void)irq;
    if (value) {
        rise_cycle[ch] = avr->cycle;
    } else if (rise_cycle[ch]) {
        double w = (double)(avr->cycle - rise_cycle[ch]) * 1e6 / avr->frequency;
        rise_cycle[ch] = 0;
        if (w < 5000.0 && (w - width_us[ch] > 0.45 || width_us[ch] - w > 0.45)) { /* hysteresis > timer-tick jitter */
            width_us[ch] = w;
            say("P %d %.2f %.2f", ch, sim_us(), w);
        }
    }
}

static void set_adc(int pin, uint32_t mv) {
    adc_mv[pin] = mv;
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + pin), mv);
}

static void print_widths(const char *tag) {
    char buf[256];
    int n = snprintf(buf, sizeof buf, "%s %.2f", tag, sim_us());
    for (int c = 0; c < NCH; c++) n += snprintf(buf + n, sizeof buf - n, " %.2f", width_us[c]);
    say("%s", buf);
}

static void do_reset(void) {
    /* simavr's reset re-initialises the peripherals; EEPROM content is kept by the eeprom
       module (like a real chip). Pin history is forgotten; analog inputs are re-applied. */
    avr_reset(avr);
    feed_active = 0; /* the reset dropped all cycle timers */
    uart_feed();
    for (int c = 0; c < NCH; c++) { rise_cycle[c] = 0; width_us[c] = 0; }
    for (int p = 0; p < 6; p++) set_adc(p, adc_mv[p]);
    if (tick_period_cycles) next_tick_cycle = avr->cycle + tick_period_cycles;
    anchor_pace();
}

/* stepped mode: a cycle timer ends the grant at its exact cycle even while the firmware sleeps */
static avr_cycle_count_t grant_timer(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a; (void)when; (void)param;
    return 0;
}

static void end_grant(void) {
    granted = 0;
    pty_pump(); /* hand the board's bytes to the pty before telling the host how many there are */
    say("HELD %.2f %llu", sim_us(), tx_total);
}

static void start_grant(double us, unsigned long long host_bytes, int lines) {
    /* the host's bytes cross the pty asynchronously: wait until all of them are here (bounded) */
    double give_up = now_wall() + 5.0;
    pty_pump();
    while (rx_total < host_bytes && rx_len < sizeof rx_buf) {
        struct pollfd pfd = {pty_master, POLLIN, 0};
        if (now_wall() > give_up) {
            say("ERR advance: %llu of %llu host bytes arrived", rx_total, host_bytes);
            return;
        }
        poll(&pfd, 1, 10);
        pty_pump();
    }
    double cycles = us * avr->frequency / 1e6;
    uint64_t whole = (uint64_t)cycles;
    if ((double)whole < cycles - 1e-6) whole++; /* at least `us`: a grant never ends before it began */
    grant_end_cycle = avr->cycle + whole;
    grant_lines = lines;
    line_done = 0;
    if (grant_end_cycle <= avr->cycle || (lines && tx_len)) { end_grant(); return; }
    avr_cycle_timer_register(avr, grant_end_cycle - avr->cycle, grant_timer, NULL);
    granted = 1;
}

/* returns 1 on `go` (continue after a tick) */
static int handle(char *line) {
    char cmd[16];
    double x = 0;
    int pin = 0, n;
    uint32_t mv = 0;
    if (sscanf(line, "%15s%n", cmd, &n) != 1) return 0;
    if (!strcmp(cmd, "run")) { running = 1; anchor_pace(); say("OK run"); }
    else if (!strcmp(cmd, "hold")) { running = 0; say("OK hold %.2f", sim_us()); }
    else if (!strcmp(cmd, "reset")) { do_reset(); say("OK reset %.2f", sim_us()); }
    else if (!strcmp(cmd, "quit")) { say("OK quit"); fflush(ctl); _exit(0); }
    else if (!strcmp(cmd, "adc")) {
        if (sscanf(line + n, "%d %u", &pin, &mv) != 2 || pin < 0 || pin > 5 || mv > 5500) say("ERR adc <pin 0-5> <mV 0-5500>");
        else set_adc(pin, mv); /* silent: sent in bulk from tick hooks */
    } else if (!strcmp(cmd, "pace")) {
        if (sscanf(line + n, "%lf", &x) != 1 || x < 0) say("ERR pace <factor >= 0>");
        else { pace = x; anchor_pace(); say("OK pace %g", pace); }
    } else if (!strcmp(cmd, "tick")) {
        if (sscanf(line + n, "%lf", &x) != 1 || x < 0) say("ERR tick <period_us>");
        else {
            tick_period_cycles = (uint64_t)(x * avr->frequency / 1e6);
            next_tick_cycle = avr->cycle + tick_period_cycles;
            say("OK tick %g", x);
        }
    } else if (!strcmp(cmd, "lockstep")) {
        int on = 0;
        if (sscanf(line + n, "%d", &on) != 1) say("ERR lockstep 0|1");
        else { lockstep = on; lock_wait = 0; say("OK lockstep %d", on); }
    } else if (!strcmp(cmd, "stepped")) {
        int on = 0;
        if (sscanf(line + n, "%d", &on) != 1) say("ERR stepped 0|1");
        else { stepped = on; granted = 0; lockstep = lock_wait = 0; anchor_pace(); say("OK stepped %d", on); }
    } else if (!strcmp(cmd, "advance")) {
        unsigned long long host_bytes = 0;
        int lines = 0;
        if (sscanf(line + n, "%lf %llu %d", &x, &host_bytes, &lines) != 3 || x < 0) say("ERR advance <us> <host bytes> <line 0|1>");
        else if (!stepped || !running || granted) say("ERR advance needs stepped 1, run and no grant running");
        else start_grant(x, host_bytes, lines); /* HELD once the grant is over */
    } else if (!strcmp(cmd, "go")) { return 1; }
    else if (!strcmp(cmd, "sleep")) {
        if (sscanf(line + n, "%lf", &x) != 1 || x < 0) say("ERR sleep <us>");
        else { wake_cycle = avr->cycle + (uint64_t)(x * avr->frequency / 1e6); waking = 1; lock_wait = 0; say("OK sleep %.2f", sim_us()); }
    } else if (!strcmp(cmd, "time")) { say("TIME %.2f", sim_us()); }
    else if (!strcmp(cmd, "pulses")) { print_widths("PULSES"); }
    else say("ERR unknown command %s", cmd);
    return 0;
}

static char inbuf[4096];
static size_t inlen;

/* read and handle control lines; wait up to timeout_ms (-1: forever) for input */
static int poll_control(int timeout_ms) {
    struct pollfd pfd = {0, POLLIN, 0};
    int got_go = 0;
    if (poll(&pfd, 1, timeout_ms) <= 0) return 0;
    ssize_t r = read(0, inbuf + inlen, sizeof inbuf - 1 - inlen);
    if (r <= 0) { fflush(ctl); _exit(0); } /* controller gone */
    inlen += (size_t)r;
    for (;;) {
        char *nl = memchr(inbuf, '\n', inlen);
        if (!nl) break;
        *nl = 0;
        got_go |= handle(inbuf);
        size_t used = (size_t)(nl - inbuf) + 1;
        memmove(inbuf, inbuf + used, inlen - used);
        inlen -= used;
    }
    if (inlen >= sizeof inbuf - 1) inlen = 0; /* absurd line: drop */
    return got_go;
}

int main(int argc, char **argv) {
    elf_firmware_t fw;
    const char *elf = 0;
    int start_running = 0;
    memset(&fw, 0, sizeof fw);
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--run")) start_running = 1;
        else if (!strcmp(argv[i], "--pace") && i + 1 < argc) pace = atof(argv[++i]);
        else elf = argv[i];
    }
    if (!elf) { fprintf(stderr, "usage: %s FIRMWARE.elf [--run] [--pace FACTOR]\n", argv[0]); return 2; }
    prctl(PR_SET_TIMERSLACK, 1000UL); /* 1 us: paced sleeps are short and frequent */
    /* keep the real stdout for the control channel; everything simavr prints goes to stderr */
    ctl = fdopen(dup(1), "w");
    dup2(2, 1);
    if (elf_read_firmware(elf, &fw) != 0) { say("ERR cannot read %s", elf); return 1; }
    avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) { say("ERR simavr has no atmega328p"); return 1; }
    avr_init(avr);
    avr_load_firmware(avr, &fw);
    avr->frequency = 16000000;
    avr->vcc = avr->avcc = avr->aref = 5000;
    avr->sleep = no_wall_sleep;
    if (pty_open() < 0) { say("ERR cannot open a pty: %s", strerror(errno)); return 1; }
    uart_connect();
    for (int c = 0; c < NCH; c++)
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), FIRST_PIN + c), pin_changed,
                                (void *)(intptr_t)c);
    for (int p = 0; p < 6; p++) set_adc(p, 0);
    say("PTY %s", pty_name);
    running = start_running;
    say("READY %s", running ? "running" : "held");
    anchor_pace();
    uint64_t next_service = 0;
    for (;;) {
        if (!running || (stepped && !granted)) { poll_control(20); if (!stepped) pty_pump(); continue; }
        if (lock_wait && !waking) {
            struct pollfd fds[2] = {{0, POLLIN, 0}, {pty_master, POLLIN, 0}};
            pty_pump(); /* deliver the reply, then wait for the host */
            if (lock_wait && ppoll(fds, 2, NULL, NULL) > 0) { pty_pump(); poll_control(0); }
            anchor_pace();
            continue;
        }
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            say("CRASH %d %.2f", state, sim_us());
            running = 0;
            if (granted) { granted = 0; say("ERR advance: the CPU stopped (state %d)", state); }
            continue;
        }
        if (tick_period_cycles && avr->cycle >= next_tick_cycle) {
            next_tick_cycle += tick_period_cycles;
            print_widths("TICK");
            while (!poll_control(-1)) {
            }
        }
        if (waking && avr->cycle >= wake_cycle) {
            waking = 0;
            if (lockstep) lock_wait = 1; /* the host reacts in zero simulated time */
            say("WOKE %.2f", sim_us());
        }
        if (granted && (avr->cycle >= grant_end_cycle || (grant_lines && line_done))) {
            end_grant();
            continue;
        }
        if (avr->cycle >= next_service) {
            /* every ~100 us of wall time (paced: 100 us x pace of simulated time; free: 1 ms):
               move UART bytes, read control lines, and when paced wait for the wall clock (or
               for host input, which ends the wait at once) */
            next_service = avr->cycle + (pace > 0 ? (uint64_t)(1600 * (pace > 1 ? pace : 1)) : 16000);
            pty_pump();
            poll_control(0);
            if (tx_len > sizeof tx_buf / 4 && !stepped) {
                /* back-pressure: a real wire delivers every byte, so a slow (descheduled) host
                   must not cost board output; simulated time stops until the pty drains */
                while (tx_len > sizeof tx_buf / 8) {
                    struct pollfd fds[2] = {{0, POLLIN, 0}, {pty_master, POLLOUT, 0}};
                    if (ppoll(fds, 2, NULL, NULL) > 0) {
                        pty_pump();
                        poll_control(0);
                    }
                }
                anchor_pace();
            }
            if (pace > 0 && !stepped) {
                double ahead = (sim_us() - sim_ref_us) / 1e6 / pace - (now_wall() - wall_ref);
                if (ahead > 0.0003) { /* sleep in chunks: each wake-up costs tens of us */
                    struct pollfd fds[2] = {{0, POLLIN, 0}, {pty_master, POLLIN, 0}};
                    struct timespec ts = {0, (long)(ahead * 1e9)};
                    if (ppoll(fds, 2, &ts, NULL) > 0) {
                        pty_pump();
                        poll_control(0);
                    }
                } else if (ahead < -0.5) {
                    anchor_pace(); /* fell far behind (slow host): do not race to catch up */
                }
            }
        }
    }
}
