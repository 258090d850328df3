"""Simulation with the FMUs (above the core): fmus (where the FMUs are, what each archive holds),
fmu_slave (one FMI 2.0 or 3.0 co-simulation slave under FMPy; _fmi_log routes the FMI 2.0 log
messages), cosim (the co-simulation master: reference -> controller FMU -> plant FMU).
"""
