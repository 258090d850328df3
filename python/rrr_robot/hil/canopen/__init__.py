"""The CANopen profile of the CAN bench (``rrr hil canopen``, docs/canopen.md): the C plant node
as three CiA 402 drives, mastered by the canopen package or by the C controller node, in
lockstep or real time. The modules: ``drives``, ``master``, ``c_master``, ``realtime``,
``results``."""
