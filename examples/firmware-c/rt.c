/* Semihosting output and exit, SysTick instruction counting, stack high-water mark. */
#include "rt.h"

/* ---- semihosting ---- */
#define SYS_WRITE0 0x04u
#define SYS_EXIT_EXTENDED 0x20u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

static uint32_t semihost(uint32_t op, const void *arg) {
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

/* The A32/T32 SYS_EXIT carries only a reason (QEMU: 0 for ApplicationExit, else 1);
   SYS_EXIT_EXTENDED takes a block {reason, subcode} and QEMU exits with the subcode. */
void semihost_exit(uint32_t code) {
    static uint32_t block[2];
    block[0] = ADP_STOPPED_APPLICATION_EXIT;
    block[1] = code;
    semihost(SYS_EXIT_EXTENDED, block);
    for (;;) __asm__ volatile("wfi");
}

static char line[256];
static size_t line_len;

static void flush(void) {
    line[line_len] = 0;
    semihost(SYS_WRITE0, line);
    line_len = 0;
}

void p_str(const char *s) {
    while (*s) {
        if (line_len == sizeof line - 1) flush();
        line[line_len++] = *s++;
    }
}

void p_nl(void) {
    p_str("\n");
    flush();
}

void p_u32(uint32_t v) {
    char b[11];
    int i = 10;
    b[i] = 0;
    do {
        b[--i] = (char)('0' + v % 10);
        v /= 10;
    } while (v);
    p_str(&b[i]);
}

void p_i32(int32_t v) {
    if (v < 0) {
        p_str("-");
        p_u32(0u - (uint32_t)v);
    } else {
        p_u32((uint32_t)v);
    }
}

void p_hex(uint32_t v) {
    char b[11] = "0x";
    for (int i = 0; i < 8; i++) b[2 + i] = "0123456789abcdef"[(v >> (28 - 4 * i)) & 0xF];
    b[10] = 0;
    p_str(b);
}

void p_fx(double x, unsigned d) {
    static const uint32_t pow10[10] = {1,      10,      100,      1000,      10000,
                                       100000, 1000000, 10000000, 100000000, 1000000000};
    if (x != x) {
        p_str("NaN");
        return;
    }
    if (x > 1e18 || x < -1e18) {
        p_str(x > 0 ? "inf" : "-inf");
        return;
    }
    if (d > 9) d = 9;
    double a = x < 0 ? -x : x;
    uint64_t m = (uint64_t)(a * pow10[d] + 0.5);
    if (x < 0 && m != 0) p_str("-");
    uint64_t whole = m / pow10[d];
    uint32_t frac = (uint32_t)(m % pow10[d]);
    /* whole < 2^32 for every value printed here; larger ones print their low digits only. */
    p_u32((uint32_t)whole);
    if (d) {
        char b[10];
        for (unsigned i = 0; i < d; i++) {
            b[d - 1 - i] = (char)('0' + frac % 10);
            frac /= 10;
        }
        b[d] = 0;
        p_str(".");
        p_str(b);
    }
}

void fatal(const char *msg) {
    p_str("FATAL ");
    p_str(msg);
    p_nl();
    semihost_exit(1);
}

/* ---- SysTick as an instruction counter ---- */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define CSR_ENABLE (1u << 0)
#define CSR_CLKSOURCE_CORE (1u << 2)
#define CSR_COUNTFLAG (1u << 16)
#define MASK 0x00FFFFFFu
/* Repetitions of every measured call: resolution 40/256 instructions. */
#define REPS 256u

static float overhead;
static uint32_t marks;
static volatile uint32_t mark;
static volatile uint32_t reps = REPS;

/* Exactly 2n instructions in the loop (n >= 1). */
__attribute__((noinline)) static void spin(uint32_t n) {
    __asm__ volatile("1:\n\tsubs %0, %0, #1\n\tbne 1b" : "+r"(n)::"cc");
}

static void spin_100k(void *ctx) {
    (void)ctx;
    spin(100000);
}

static void spin_300k(void *ctx) {
    (void)ctx;
    spin(300000);
}

/* SysTick ticks spent in f(ctx) (one call, at most 2^24 ticks). */
__attribute__((noinline, noipa)) static uint32_t ticks_of(bench_fn f, void *ctx) {
    (void)SYST_CSR; /* reading clears COUNTFLAG */
    uint32_t s = SYST_CVR;
    f(ctx);
    uint32_t e = SYST_CVR;
    bool wrapped = (SYST_CSR & CSR_COUNTFLAG) != 0;
    uint32_t t = (s - e) & MASK;
    return (wrapped && t == 0) ? MASK + 1 : t;
}

uint32_t insns_of(bench_fn f, void *ctx) { return ticks_of(f, ctx) * INSNS_PER_TICK; }

struct repeat {
    bench_fn f;
    void *ctx;
    uint32_t calls;
    uint32_t id;
};

__attribute__((noinline, noipa)) static void repeat_loop(void *ctx) {
    struct repeat *r = ctx;
    for (uint32_t i = 0, n = reps; i < n; i++) r->f(r->ctx);
}

static float per_call_raw(bench_fn f, void *ctx) {
    struct repeat r = {f, ctx, 0, 0};
    uint32_t t = ticks_of(repeat_loop, &r);
    return (float)(t * INSNS_PER_TICK) / (float)REPS;
}

__attribute__((noinline, noipa)) static void marker_free(void *ctx) { (void)ctx; }

void counter_init(void) {
    SYST_RVR = MASK;
    SYST_CVR = 0;
    SYST_CSR = CSR_CLKSOURCE_CORE | CSR_ENABLE; /* no interrupt */
    /* 400,000 instructions apart = 10,000 ticks. */
    uint32_t a = ticks_of(spin_100k, 0);
    uint32_t b = ticks_of(spin_300k, 0);
    uint32_t ticks = b - a, expected = 400000u / INSNS_PER_TICK;
    if (ticks + 1 < expected || ticks > expected + 1) {
        p_str("FATAL SysTick does not count instructions (");
        p_u32(ticks);
        p_str(" ticks for 400,000 instructions, expected ");
        p_u32(expected);
        p_str("): run QEMU with -icount shift=0");
        p_nl();
        semihost_exit(1);
    }
    overhead = per_call_raw(marker_free, 0);
}

static void measured(uint32_t id, uint32_t insns) {
    p_str("MEASURE ");
    p_u32(id);
    p_str(" ");
    p_u32(insns);
    p_nl();
}

float per_call(bench_fn f, void *ctx) {
    uint32_t id = marks++;
    bench_start(id);
    f(ctx);
    bench_stop(id);
    float n = per_call_raw(f, ctx) - overhead;
    measured(id, (uint32_t)(n + 0.5f));
    return n;
}

__attribute__((noinline, noipa)) static void once_loop(void *ctx) {
    struct repeat *r = ctx;
    bench_start(r->id);
    for (uint32_t i = 0; i < r->calls; i++) r->f(r->ctx);
    bench_stop(r->id);
}

float per_call_once(uint32_t calls, bench_fn f, void *ctx) {
    struct repeat r = {f, ctx, calls, marks++};
    uint32_t total = ticks_of(once_loop, &r) * INSNS_PER_TICK;
    measured(r.id, total);
    return ((float)total - overhead * (float)calls) / (float)calls;
}

__attribute__((noinline, noipa)) void bench_start(uint32_t id) { mark = id; }
__attribute__((noinline, noipa)) void bench_stop(uint32_t id) { mark = ~id; }

/* ---- stack ---- */
extern uint32_t __bss_end__, __stack_top__;

uint32_t stack_high_water(void) {
    const volatile uint32_t *p = &__bss_end__;
    uintptr_t top = (uintptr_t)&__stack_top__;
    while ((uintptr_t)p < top && *p == 0xCCCCCCCCu) p++;
    return (uint32_t)(top - (uintptr_t)p);
}
