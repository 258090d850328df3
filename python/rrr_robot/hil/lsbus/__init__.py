"""The CAN bench inside co-simulation (``rrr ls-bus``): the controller and the plant as network
FMUs of FMI-LS-BUS 1.0 (``fmu/controller_can``, ``fmu/plant_can``: the C nodes' DBC profile on
an FMI 3.0 CAN terminal), assembled by fmucontainer (fmu_manipulation_toolbox) directly or
through the open CAN bus simulation FMU, and run by FMPy.

``container`` (the container and its node copies), ``run`` (the run, turned into the files of
``rrr hil bench``), ``datalog`` (the container's data log: bus operations, the frame log, pcap).
docs/ls-bus.md is the manual's page.
"""
