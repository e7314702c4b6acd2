/*
 * The least a C program needs to run on the Cortex-M4F of QEMU's mps2-an386 board with newlib:
 * a vector table, a reset handler that turns the FPU on (the library is built for the hard-float
 * ABI) and enters newlib's rdimon start-up, which takes the command line and does file I/O over
 * semihosting. A real gyro's vendor start-up file does the same and more.
 */
#include <stdint.h>
#include <stdio.h>

extern void _start(void);
extern uint32_t __stack_top;

/* The stack's high-water mark. newlib's start-up moves the stack to where the semihosting host
 * says it is, so the measure starts after it: a constructor fills the RAM below its own frame
 * with a pattern, and at exit the deepest word no longer holding it shows how much stack main
 * and everything it called used (printed on stderr; `firmware-sim`'s C runner reads it). */
#define PAINT 0xA5C3F00Du
#define WINDOW_WORDS (256u * 1024u)

static uint32_t *stack_base;

__attribute__((constructor)) static void paint_stack(void) {
    stack_base = (uint32_t *)__builtin_frame_address(0);
    for (uint32_t *p = stack_base - WINDOW_WORDS; p < stack_base - 64; p++) {
        *(volatile uint32_t *)p = PAINT;
    }
}

__attribute__((destructor)) static void report_stack(void) {
    const uint32_t *p = stack_base - WINDOW_WORDS;
    while (p < stack_base && *p == PAINT) {
        p++;
    }
    fprintf(stderr, "stack: %lu bytes\n", (unsigned long)((stack_base - p) * 4));
}

void reset_handler(void) {
    /* CPACR: full access to CP10 and CP11 (the FPU) before any floating-point instruction. */
    *(volatile uint32_t *)0xE000ED88 |= (0xFu << 20);
    __asm volatile("dsb\n isb");
    _start();
    for (;;) {
    }
}

static void hang(void) {
    for (;;) {
    }
}

/* newlib's init and fini hooks: nothing to run on this board. */
void _init(void) {}
void _fini(void) {}

__attribute__((section(".vectors"), used)) const void *const vectors[16] = {
    &__stack_top, (const void *)reset_handler, (const void *)hang, (const void *)hang,
    (const void *)hang, (const void *)hang, (const void *)hang, 0, 0, 0, 0,
    (const void *)hang, (const void *)hang, 0, (const void *)hang, (const void *)hang,
};
