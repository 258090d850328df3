/* Reset and the vector table of the firmware (ARMv7-M: Cortex-M4 and M7 alike). */
#include <stdint.h>
#include <string.h>

#include "mps2.h"

extern uint32_t __stack_top[];
extern char __data_start[], __data_source[], __data_size[];
extern char __bss_start[], __bss_size[];
extern char __tls_base[];

void _set_tls(void *tls); /* picolibc: the thread pointer (errno lives in TLS) */
int main(void);
void pil_reset(void);
void pil_uart0_rx_irq(void);
void pil_timer1_irq(void);
void pil_fault(void);

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)

void pil_reset(void)
{
    /* the FPU (CP10, CP11: full access) before any floating-point instruction */
    SCB_CPACR |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
    memcpy(__data_start, __data_source, (size_t)__data_size);
    memset(__bss_start, 0, (size_t)__bss_size);
    _set_tls(__tls_base);
    pil_exit(main());
}

/* Any fault or unexpected interrupt ends the run with status 5 ("fault") and one line. */
void pil_fault(void)
{
    static const char msg[] = "rrr_pil: fault (HardFault or an unexpected exception)\n";
    (void)fputs(msg, stdout);
    pil_exit(5);
}

typedef void (*pil_vector)(void);

__attribute__((section(".vectors"), used)) static const pil_vector vectors[16 + 32] = {
    (pil_vector)(uintptr_t)__stack_top,
    pil_reset,
    pil_fault, /* NMI */
    pil_fault, /* HardFault */
    pil_fault, /* MemManage */
    pil_fault, /* BusFault */
    pil_fault, /* UsageFault */
    0, 0, 0, 0,
    pil_fault, /* SVCall */
    pil_fault, /* DebugMonitor */
    0,
    pil_fault, /* PendSV */
    pil_fault, /* SysTick */
    pil_uart0_rx_irq, /* IRQ 0: UART0 RX */
    pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault,
    pil_timer1_irq, /* IRQ 9: timer 1 */
    pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault,
    pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault,
    pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault, pil_fault,
};
