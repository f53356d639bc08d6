/* Reset and fault handling of the C firmware on the Cortex-M4F (QEMU mps2-an386): the vector
   table, Reset_Handler (FPU on before any float code, .data copied, .bss zeroed, the stack
   painted for the high-water mark) and a HardFault handler that prints FATAL and exits 1. */
#include "rt.h"

extern uint32_t __data_start__, __data_end__, __data_load__, __bss_start__, __bss_end__;
extern uint32_t __stack_top__;
int main(void);

void Reset_Handler(void);
void HardFault_Handler(void);
void Default_Handler(void);

/* The word the stack is painted with (cortex-m-rt's paint-stack uses the same). */
#define STACK_PAINT 0xCCCCCCCCu

/* Cortex-M vector table: initial stack pointer, then the 15 system exceptions (the MPS2's
   external interrupts are never enabled, so none are listed). */
__attribute__((section(".vector_table"), used)) void (*const vector_table[16])(void) = {
    (void (*)(void))(uintptr_t)&__stack_top__,
    Reset_Handler,
    Default_Handler, /* NMI */
    HardFault_Handler,
    HardFault_Handler, /* MemManage: escalates to HardFault when disabled anyway */
    HardFault_Handler, /* BusFault */
    HardFault_Handler, /* UsageFault */
    0, 0, 0, 0,
    Default_Handler, /* SVCall */
    Default_Handler, /* DebugMonitor */
    0,
    Default_Handler, /* PendSV */
    Default_Handler, /* SysTick (its interrupt stays disabled) */
};

/* No float code here, and volatile accesses so the compiler turns no loop into a library call:
   the FPU is off until CPACR is written, and .data/.bss are not set up yet. */
__attribute__((noreturn, used)) void Reset_Handler(void) {
    /* CP10 and CP11 full access (CPACR, 0xE000ED88), then barriers before any FP instruction. */
    *(volatile uint32_t *)0xE000ED88u |= (0xFu << 20);
    __asm__ volatile("dsb\n\tisb" ::: "memory");

    volatile uint32_t *src = &__data_load__;
    for (volatile uint32_t *dst = &__data_start__; dst < &__data_end__;) *dst++ = *src++;
    for (volatile uint32_t *p = &__bss_start__; p < &__bss_end__;) *p++ = 0;

    /* Paint from the end of .bss up to just below the current stack pointer. */
    uint32_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (volatile uint32_t *p = &__bss_end__; (uintptr_t)p < (sp & ~7u) - 64u;) *p++ = STACK_PAINT;

    main();
    fatal("main returned");
}

/* The stacked frame: r0-r3, r12, lr, pc, xpsr. */
__attribute__((noreturn, used)) void hard_fault_c(const uint32_t *frame) {
    p_str("FATAL HardFault at pc ");
    p_hex(frame[6]);
    p_nl();
    semihost_exit(1);
}

__attribute__((naked)) void HardFault_Handler(void) {
    __asm__ volatile(
        "tst lr, #4\n\t"
        "ite eq\n\t"
        "mrseq r0, msp\n\t"
        "mrsne r0, psp\n\t"
        "b hard_fault_c\n\t");
}

__attribute__((noreturn)) void Default_Handler(void) { fatal("unexpected exception"); }
