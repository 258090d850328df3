"""model/: librrr and the model against independent references and their own generated code:
the closed-form dynamics against Pinocchio, MuJoCo and Drake, the generated C, librrr's exports,
the native closed loop and its signals, the URDF export read by other readers. Marker
``slow``."""

from support.markers import folder_markers

pytest_ignore_collect = folder_markers(__file__, "slow")
