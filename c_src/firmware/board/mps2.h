/**
 * @file mps2.h
 * @brief The board layer of the firmware on the Arm MPS2 boards that QEMU emulates (mps2-an500:
 *        Cortex-M7 with a double-precision FPU; mps2-an386: Cortex-M4 with a single-precision
 *        FPU): three CMSDK UARTs, a CMSDK timer, the stack's high-water mark, the end of a run.
 *        Everything else of the firmware is board independent: porting to a real board means
 *        this file's functions, startup.c and the linker script (docs/microcontroller.md).
 *
 *  - UART0: the SLCAN line (the CAN bus as a CANable-type adapter's serial protocol); received
 *    bytes go into a ring buffer from the RX interrupt, the firmware sleeps (WFI) while it is
 *    empty;
 *  - UART1: the controller log (CSV, one row per period), as a stdio stream;
 *  - UART2: the console (stdout: the summary line and messages);
 *  - UART3: the instruction counts, one CSV row per period (pil_timing);
 *  - timer 0: a free-running counter of the board clock. Under QEMU with `-icount shift=0`
 *    every instruction advances the virtual clock by 1 ns, so the ticks between two reads
 *    count instructions (PIL_BOARD_NS_PER_TICK of them per tick), not cycles;
 *  - timer 1: an interrupt every 10 ms that wakes the sleeping firmware to check its timeout.
 */
#ifndef PIL_MPS2_H
#define PIL_MPS2_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/** The board clock of the MPS2 FPGA images (SYSCLK, which clocks the CMSDK timers): 25 MHz. */
#define PIL_BOARD_CLOCK_HZ 25000000u
/** Nanoseconds of virtual time per timer tick (40): instructions per tick under -icount shift=0. */
#define PIL_BOARD_NS_PER_TICK (1000000000u / PIL_BOARD_CLOCK_HZ)

/** Set up the UARTs, the timer and the RX interrupt; paint the unused stack. */
void pil_board_init(void);

/** The next byte of the SLCAN line, sleeping until one arrives or the timer reaches
 *  @p deadline (pil_ticks): -1 then. */
int pil_slcan_getc_until(uint32_t deadline);
/** Write n bytes to the SLCAN line. */
void pil_slcan_write(const char *s, size_t n);

/** The controller log (UART1). */
extern FILE *const pil_log;
/** The instruction counts (UART3). */
extern FILE *const pil_timing;

/** The free-running timer, counting up (wraps after 2^32 ticks: 171 s). */
uint32_t pil_ticks(void);

/** Interrupts off / back on (PRIMASK): a timed section sees no interrupt handler's instructions. */
void pil_irq_off(void);
void pil_irq_on(void);

/** Bytes of the main stack ever used: the painted words that were overwritten. */
size_t pil_stack_used(void);
/** Bytes reserved for the main stack (the linker script's PIL_STACK_SIZE). */
size_t pil_stack_size(void);

/** End the run with an exit status: under QEMU through semihosting (SYS_EXIT_EXTENDED: QEMU
 *  exits with it); on a board without a debugger this would halt instead. */
_Noreturn void pil_exit(int status);

#endif /* PIL_MPS2_H */
