/* The C firmware's runtime: semihosting output and exit, SysTick instruction counting, the
   stack high-water mark. Bare metal, no libc. */
#ifndef KINECAL_FIRMWARE_C_RT_H
#define KINECAL_FIRMWARE_C_RT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---- output (semihosting SYS_WRITE0, one call per line) ---- */
void p_str(const char *s);
void p_u32(uint32_t v);
void p_i32(int32_t v);
void p_hex(uint32_t v);
/* `x` with `d` decimals (at most 9) by integer arithmetic, as the Rust firmware's `Fixed`. */
void p_fx(double x, unsigned d);
/* Ends the line and hands it to the host. */
void p_nl(void);

/* Ends the QEMU run with `code` as its exit status (SYS_EXIT_EXTENDED). */
__attribute__((noreturn)) void semihost_exit(uint32_t code);
/* Prints `FATAL <msg>` and exits with status 1. */
__attribute__((noreturn)) void fatal(const char *msg);

/* ---- instruction counting (bench.c) ---- */
/* Instructions per SysTick tick under -icount shift=0 on the MPS2 board (25 MHz core clock). */
#define INSNS_PER_TICK 40u
typedef void (*bench_fn)(void *ctx);
/* Starts SysTick and verifies the 40-to-1 ratio on a loop of known length (fatal if not). */
void counter_init(void);
/* Instructions of one run of f(ctx) (resolution 40). */
uint32_t insns_of(bench_fn f, void *ctx);
/* Instructions of one call of f(ctx), repeated 256 times, loop overhead removed. */
float per_call(bench_fn f, void *ctx);
/* Instructions per call of `calls` consecutive calls of a stateful f(ctx), measured once. */
float per_call_once(uint32_t calls, bench_fn f, void *ctx);
/* Bytes of stack ever used (painted at reset). */
uint32_t stack_high_water(void);

/* Markers for QEMU's instruction-counting plugin (as the Rust firmware's). */
void bench_start(uint32_t id);
void bench_stop(uint32_t id);

#endif
