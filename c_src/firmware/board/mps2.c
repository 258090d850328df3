/* The MPS2 board layer (mps2.h): CMSDK UARTs and timer, the stack's paint, semihosting exit. */
#include "mps2.h"

/* CMSDK APB UART (Arm's Cortex-M System Design Kit) */
typedef struct cmsdk_uart {
    volatile uint32_t data;
    volatile uint32_t state; /* bit 0: TX full, bit 1: RX full */
    volatile uint32_t ctrl;  /* bit 0: TX enable, bit 1: RX enable, bit 3: RX interrupt */
    volatile uint32_t intstatus; /* write 1s to clear: bit 0 TX, bit 1 RX */
    volatile uint32_t bauddiv;
} cmsdk_uart;

/* CMSDK APB timer */
typedef struct cmsdk_timer {
    volatile uint32_t ctrl; /* bit 0: enable */
    volatile uint32_t value;
    volatile uint32_t reload;
    volatile uint32_t intstatus;
} cmsdk_timer;

#define UART0 ((cmsdk_uart *)0x40004000u)
#define UART1 ((cmsdk_uart *)0x40005000u)
#define UART2 ((cmsdk_uart *)0x40006000u)
#define UART3 ((cmsdk_uart *)0x40007000u)
#define TIMER0 ((cmsdk_timer *)0x40000000u)
#define TIMER1 ((cmsdk_timer *)0x40001000u)
#define NVIC_ISER0 (*(volatile uint32_t *)0xE000E100u)
/* the MPS2 images' interrupts: UART0's receiver, timer 1 */
#define UART0_RX_IRQ 0u
#define TIMER1_IRQ 9u

#define STACK_PAINT 0xC0FFEE11u

extern uint32_t __stack_limit[];
extern uint32_t __stack_top[];

/* The RX ring: written by the interrupt, read by pil_slcan_getc (single producer, consumer). */
static volatile uint8_t rx_ring[1024];
static volatile uint32_t rx_head, rx_tail;

void pil_uart0_rx_irq(void);
void pil_timer1_irq(void);

void pil_timer1_irq(void)
{
    TIMER1->intstatus = 1u; /* the wake-up of pil_slcan_getc_until: nothing else to do */
}

void pil_uart0_rx_irq(void)
{
    /* clear the interrupt before draining: a byte that arrives after the last check raises it
     * again (cleared after, it would sit in the data register with no interrupt to fetch it) */
    UART0->intstatus = 2u;
    while (UART0->state & 2u) {
        const uint32_t next = (rx_head + 1u) % sizeof rx_ring;
        if (next == rx_tail) {
            break; /* full: QEMU holds the rest of the input until we read again */
        }
        rx_ring[rx_head] = (uint8_t)UART0->data;
        rx_head = next;
    }
}

static void uart_init(cmsdk_uart *u, uint32_t ctrl)
{
    u->bauddiv = 16u; /* the smallest divider QEMU accepts; the rate itself is not modelled */
    u->ctrl = ctrl;
}

static void uart_putc(cmsdk_uart *u, char c)
{
    while (u->state & 1u) {
    }
    u->data = (uint8_t)c;
}

static int log_putc(char c, FILE *f)
{
    (void)f;
    uart_putc(UART1, c);
    return (unsigned char)c;
}

static int timing_putc(char c, FILE *f)
{
    (void)f;
    uart_putc(UART3, c);
    return (unsigned char)c;
}

static int console_putc(char c, FILE *f)
{
    (void)f;
    uart_putc(UART2, c);
    return (unsigned char)c;
}

static FILE log_file = FDEV_SETUP_STREAM(log_putc, NULL, NULL, _FDEV_SETUP_WRITE);
static FILE console_file = FDEV_SETUP_STREAM(console_putc, NULL, NULL, _FDEV_SETUP_WRITE);
static FILE timing_file = FDEV_SETUP_STREAM(timing_putc, NULL, NULL, _FDEV_SETUP_WRITE);
FILE *const pil_log = &log_file;
FILE *const pil_timing = &timing_file;
/* picolibc's stdout and stderr: the console */
FILE *const stdout = &console_file;
FILE *const stderr = &console_file;

void pil_irq_off(void)
{
    __asm volatile("cpsid i" ::: "memory");
}

void pil_irq_on(void)
{
    __asm volatile("cpsie i" ::: "memory");
}

void pil_board_init(void)
{
    /* paint the stack up to 256 bytes below the current frame */
    uintptr_t sp;
    __asm volatile("mov %0, sp" : "=r"(sp));
    for (uint32_t *p = __stack_limit; (uintptr_t)(p + 64) < sp; ++p) {
        *p = STACK_PAINT;
    }
    uart_init(UART0, 0x1u | 0x2u | 0x8u);
    uart_init(UART1, 0x1u);
    uart_init(UART2, 0x1u);
    uart_init(UART3, 0x1u);
    TIMER0->ctrl = 0u;
    TIMER0->reload = 0xFFFFFFFFu;
    TIMER0->value = 0xFFFFFFFFu;
    TIMER0->ctrl = 1u;
    TIMER1->ctrl = 0u;
    TIMER1->reload = PIL_BOARD_CLOCK_HZ / 100u;
    TIMER1->value = PIL_BOARD_CLOCK_HZ / 100u;
    TIMER1->ctrl = 1u | 8u; /* enabled, interrupt */
    NVIC_ISER0 = (1u << UART0_RX_IRQ) | (1u << TIMER1_IRQ);
    pil_irq_on();
}

int pil_slcan_getc_until(uint32_t deadline)
{
    for (;;) {
        pil_irq_off();
        pil_uart0_rx_irq(); /* a byte left in the data register while the ring was full */
        if (rx_tail != rx_head) {
            const uint8_t c = rx_ring[rx_tail];
            rx_tail = (rx_tail + 1u) % sizeof rx_ring;
            pil_irq_on();
            return c;
        }
        if ((int32_t)(pil_ticks() - deadline) >= 0) {
            pil_irq_on();
            return -1;
        }
        /* a pending interrupt wakes WFI even with PRIMASK set: no byte is missed between the
         * check and the sleep; timer 1 wakes it every 10 ms for the deadline */
        __asm volatile("wfi" ::: "memory");
        pil_irq_on();
    }
}

void pil_slcan_write(const char *s, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        uart_putc(UART0, s[i]);
    }
}

uint32_t pil_ticks(void)
{
    return 0xFFFFFFFFu - TIMER0->value;
}

size_t pil_stack_used(void)
{
    const uint32_t *p = __stack_limit;
    while (p < __stack_top && *p == STACK_PAINT) {
        ++p;
    }
    return (size_t)((const char *)__stack_top - (const char *)p);
}

size_t pil_stack_size(void)
{
    return (size_t)((const char *)__stack_top - (const char *)__stack_limit);
}

_Noreturn void pil_exit(int status)
{
    /* semihosting SYS_EXIT_EXTENDED (0x20): ADP_Stopped_ApplicationExit with the status */
    static uint32_t block[2];
    block[0] = 0x20026u;
    block[1] = (uint32_t)status;
    register uint32_t r0 __asm("r0") = 0x20u;
    register uint32_t *r1 __asm("r1") = block;
    __asm volatile("bkpt 0xAB" : : "r"(r0), "r"(r1) : "memory");
    for (;;) {
        __asm volatile("wfi");
    }
}
