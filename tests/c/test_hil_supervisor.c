/* The plant's command supervisor: the safety policy of hil_supervisor.h, period by period. */
#include <string.h>

#include "hil_supervisor.h"
#include "rrr_test.h"

static rrr_hil_sup fresh(void)
{
    rrr_hil_sup s;
    const rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
    CHECK(rrr_hil_sup_init(&s, &cfg) == 0);
    return s;
}

static rrr_hil_voltage_cmd cmd(uint8_t counter, double u)
{
    const rrr_hil_voltage_cmd c = {(uint8_t)(counter & 15u), 1, 0, {u, -u, 2.0 * u}};
    return c;
}

static int period(rrr_hil_sup *s, double u[3])
{
    return rrr_hil_sup_next_period(s, u);
}

static void test_normal_and_hold(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    for (uint8_t k = 0; k < 40; ++k) {
        const rrr_hil_voltage_cmd c = cmd(k, 0.1 * k);
        rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
        CHECK(period(&s, u) == 0);
        CHECK(u[0] == 0.1 * k && u[1] == -(0.1 * k) && u[2] == 2.0 * (0.1 * k));
    }
    /* one dropped frame: the last voltage is held, then the next counter (delta 2) is fine */
    CHECK(period(&s, u) == 0 && u[0] == 0.1 * 39);
    rrr_hil_voltage_cmd c = cmd(41, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 1.0);
    /* two dropped: held twice */
    CHECK(period(&s, u) == 0 && u[0] == 1.0);
    CHECK(period(&s, u) == 0 && u[0] == 1.0);
    c = cmd(44, 2.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 2.0);
    CHECK(s.faults == 0 && s.err.cmd_missed == 3 && s.err.fault_events == 0);
    /* Enable = 0: 0 V, not a fault */
    c = cmd(45, 2.0);
    c.enable = 0;
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 0.0 && s.faults == 0);
}

static void test_silent_controller(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    const rrr_hil_voltage_cmd c = cmd(0, 3.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && u[0] == 3.0);
    CHECK(period(&s, u) == 0 && u[0] == 3.0);  /* 1st silent period: hold */
    CHECK(period(&s, u) == 0 && u[0] == 3.0);  /* 2nd: hold */
    CHECK(period(&s, u) == 1 && u[0] == 0.0);  /* 3rd: 0 V and latched */
    CHECK(s.faults == RRR_HIL_FAULT_TIMEOUT && s.err.timeout == 1);
    for (int k = 0; k < 10; ++k) {
        CHECK(period(&s, u) == 1 && u[0] == 0.0 && u[1] == 0.0 && u[2] == 0.0);
    }
    CHECK(s.err.timeout == 1 && s.err.fault_events == 1 && s.err.cmd_missed == 13);
    /* the controller comes back: still 0 V (latched) */
    rrr_hil_voltage_cmd back = cmd(1, 3.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &back);
    CHECK(period(&s, u) == 1 && u[0] == 0.0);
    /* reset: ResetFault with Enable = 0 */
    back = cmd(2, 0.0);
    back.enable = 0;
    back.reset_fault = 1;
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &back);
    CHECK(period(&s, u) == 0 && s.faults == 0 && s.err.resets == 1);
    back = cmd(3, 1.5);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &back);
    CHECK(period(&s, u) == 0 && u[0] == 1.5);
    rrr_hil_plant_status st;
    rrr_hil_sup_status(&s, &st);
    CHECK(st.state == RRR_HIL_PLANT_RUNNING && st.fault_count == 1 && st.cmd_missed == 13);
}

static void test_immediate_faults(void)
{
    const struct {
        rrr_hil_rx rx;
        uint8_t fault;
    } cases[] = {{RRR_HIL_RX_BAD_CRC, RRR_HIL_FAULT_CRC},
                 {RRR_HIL_RX_OUT_OF_RANGE, RRR_HIL_FAULT_RANGE},
                 {RRR_HIL_RX_BAD_DLC, RRR_HIL_FAULT_FORMAT}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        rrr_hil_sup s = fresh();
        double u[3];
        rrr_hil_voltage_cmd c = cmd(0, 3.0);
        rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
        CHECK(period(&s, u) == 0 && u[0] == 3.0);
        /* a valid command, then a bad frame in the same period: the bad one wins, 0 V at once */
        c = cmd(1, 4.0);
        rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
        rrr_hil_sup_on_command(&s, cases[i].rx, NULL);
        CHECK(period(&s, u) == 1 && u[0] == 0.0);
        CHECK(s.faults == cases[i].fault && s.err.fault_events == 1);
        rrr_hil_plant_status st;
        rrr_hil_sup_status(&s, &st);
        CHECK(st.state == RRR_HIL_PLANT_FAULT && st.faults == cases[i].fault && st.zero_voltage == 1);
    }
}

static void test_counter(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    rrr_hil_voltage_cmd c = cmd(5, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c); /* repeated counter */
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_COUNTER && s.err.counter == 1);

    s = fresh();
    c = cmd(15, 1.0);
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0);
    c = cmd(2, 1.0); /* 15 -> 2 is a wrap-around delta of 3: accepted */
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 0 && s.faults == 0);
    c = cmd(6, 1.0); /* delta 4 > max_delta_counter */
    rrr_hil_sup_on_command(&s, RRR_HIL_RX_OK, &c);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_COUNTER);
}

static void test_external_and_config(void)
{
    rrr_hil_sup s = fresh();
    double u[3];
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_BUS);
    rrr_hil_sup_raise(&s, RRR_HIL_FAULT_SYNC);
    CHECK(period(&s, u) == 1 && s.faults == (RRR_HIL_FAULT_BUS | RRR_HIL_FAULT_SYNC));
    CHECK(s.err.bus == 1 && s.err.sync == 1 && s.err.fault_events == 2);
    const rrr_hil_sup_config bad1 = {0u, 3u}, bad2 = {3u, 16u}, one = {1u, 1u};
    CHECK(rrr_hil_sup_init(&s, &bad1) == -1);
    CHECK(rrr_hil_sup_init(&s, &bad2) == -1);
    CHECK(rrr_hil_sup_init(&s, &one) == 0);
    CHECK(period(&s, u) == 1 && s.faults == RRR_HIL_FAULT_TIMEOUT); /* max_missed 1: at once */
}

int main(void)
{
    test_normal_and_hold();
    test_silent_controller();
    test_immediate_faults();
    test_counter();
    test_external_and_config();
    return rrr_test_report("test_hil_supervisor");
}
