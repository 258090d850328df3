"""Patch the vendored CAN bus simulation FMU (third_party/fmi-ls-bus-examples/can-bus-simulation)
for fmucontainer 2.0, at build time: its Tx clocks become triggered output clocks.

Why: fmucontainer 2.0 hands a countdown-clocked value to no FMU (it activates the receivers'
clocks but never sets the clocked Binary inputs: measured, docs/ls-bus.md), so the unmodified
bus simulation delivers no frame. Patched, the bus asks for an event (eventHandlingNeeded from
fmi3DoStep) at the first communication point at or after the end of the frame on the bus,
and raises both Tx clocks there once fmi3UpdateDiscreteStates has run in that event (a value
released before it reaches only the FMUs listed before the bus). A node's answer in the same
instant (an input set after the event's evaluation) is kept for the next evaluation instead of
being refused. The frame timing (44 + data length bits at the configured baud rate), the
arbitration and the error injection are the original's.

Usage: python patch_bus_simulation.py SRC_DIR OUT_DIR   (SRC_DIR: can-bus-simulation/)
Each replacement must match exactly as often as stated, so a new upstream version that no
longer fits fails the build instead of being patched wrongly.
"""

from __future__ import annotations

import sys
from pathlib import Path

APP = [
    ("""    fmi3Float64 SimulationTime;
};""", """    fmi3Float64 SimulationTime;
    bool TxDue;             /* rrr: the next frame's end has been reached: tick the Tx clocks */
    bool TxArmed;           /* rrr: fmi3UpdateDiscreteStates was called in this event */
    fmi3Float64 NextTxTime; /* rrr: the end of the frame on the bus, s */
};""", 1),
    ("""    instance->App->SimulationTime = targetTime;
    /* Return whether event mode is needed */
    return false;""", """    instance->App->SimulationTime = targetTime;
    instance->App->TxArmed = false;
    if (instance->App->TxClockSet && instance->App->TxClockResolution > 0 &&
        targetTime >= instance->App->NextTxTime - 1e-12)
    {
        instance->App->TxDue = true;
    }
    /* Return whether event mode is needed */
    return instance->App->TxDue;""", 1),
    ("""            instance->App->TxClockSet = true;""", """            instance->App->TxClockSet = true;
            instance->App->NextTxTime = instance->App->SimulationTime +
                (instance->App->TxClockResolution > 0
                     ? (fmi3Float64)instance->App->TxClockCounter /
                           (fmi3Float64)instance->App->TxClockResolution
                     : 0.0);""", 1),
    ("""bool App_GetClock(FmuInstance* instance, fmi3ValueReference valueReference, fmi3Clock* value)
{
    return false;
}""", """bool App_GetClock(FmuInstance* instance, fmi3ValueReference valueReference, fmi3Clock* value)
{
    if (valueReference != FMU_VAR_NODE1_TX_CLOCK && valueReference != FMU_VAR_NODE2_TX_CLOCK)
    {
        return false;
    }
    if (instance->App->TxDue && instance->App->TxArmed)
    {
        instance->App->TxDue = false;
        instance->App->Nodes[0].TxClock = fmi3ClockActive;
        instance->App->Nodes[1].TxClock = fmi3ClockActive;
    }
    *value = valueReference == FMU_VAR_NODE1_TX_CLOCK ? instance->App->Nodes[0].TxClock
                                                       : instance->App->Nodes[1].TxClock;
    return true;
}""", 1),
    ("""    instance->App->DiscreteStatesEvaluated = false;
}""", """    instance->App->DiscreteStatesEvaluated = false;
    instance->App->TxArmed = true;
}""", 1),
    ("""    if (instance->App->DiscreteStatesEvaluated)
    {
        LogFmuMessage(instance, fmi3Error, "Error",
                      "Discrete states have already been evaluated, cannot set input variable");
        return false;
    }
""", """    /* rrr: an input set after this event's evaluation (a node answering in the same instant)
     * is kept for the next evaluation */
""", 2),
]

XML = [
    ('<Clock name="Node1.Tx_Clock" valueReference="3" causality="input" '
     'intervalVariability="countdown" />',
     '<Clock name="Node1.Tx_Clock" valueReference="3" causality="output" '
     'intervalVariability="triggered" />', 1),
    ('<Clock name="Node2.Tx_Clock" valueReference="7" causality="input" '
     'intervalVariability="countdown" />',
     '<Clock name="Node2.Tx_Clock" valueReference="7" causality="output" '
     'intervalVariability="triggered" />', 1),
    ("""    <Output valueReference="5" dependencies="7" />""",
     """    <Output valueReference="5" dependencies="7" />
    <Output valueReference="3" />
    <Output valueReference="7" />
    <InitialUnknown valueReference="3" />
    <InitialUnknown valueReference="7" />""", 1),
]


def patch(text: str, rules: list[tuple[str, str, int]], name: str) -> str:
    for old, new, count in rules:
        found = text.count(old)
        if found != count:
            raise SystemExit(f"patch_bus_simulation: {name}: expected {count} match(es) of "
                             f"{old.splitlines()[0]!r}, found {found}")
        text = text.replace(old, new)
    return text


def main() -> None:
    src, out = Path(sys.argv[1]), Path(sys.argv[2])
    (out / "src").mkdir(parents=True, exist_ok=True)
    (out / "description").mkdir(parents=True, exist_ok=True)
    app = (src / "src" / "App.c").read_text(encoding="utf-8")
    (out / "src" / "App.c").write_text(patch(app, APP, "App.c"), encoding="utf-8")
    xml = (src / "description" / "modelDescription.xml").read_text(encoding="utf-8")
    (out / "description" / "modelDescription.xml").write_text(
        patch(xml, XML, "modelDescription.xml"), encoding="utf-8")


if __name__ == "__main__":
    main()
