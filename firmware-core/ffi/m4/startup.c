/*
 * The least a C program needs to run on the Cortex-M4F of QEMU's mps2-an386 board with newlib:
 * a vector table, a reset handler that turns the FPU on (the library is built for the hard-float
 * ABI) and enters newlib's rdimon start-up, which takes the command line and does file I/O over
 * semihosting. A real gyro's vendor start-up file does the same and more.
 */
#include <stdint.h>

extern void _start(void);
extern uint32_t __stack_top;

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
