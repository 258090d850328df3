"""An FMU's optional resources/start_values.csv (fmu/common: FMU_START_FILE): its values replace
the compiled start values at instantiation and at reset, with the checks of SetReal and
SetBoolean in state Instantiated; a malformed file stops the instantiation with a message that
names the line and what is wrong. rrr ssp writes one into each FMU of its archive."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from support.fmu_support import Slave, fmu_file, unzipped


def copy_with(tmp_path: Path, which: str, text: str | bytes | None) -> Path:
    """An unzipped copy of the packaged FMU with resources/start_values.csv holding ``text``."""
    folder = tmp_path / which
    shutil.copytree(unzipped(fmu_file(which)), folder)
    target = folder / "resources" / "start_values.csv"
    target.parent.mkdir(exist_ok=True)
    if text is not None:
        target.write_bytes(text if isinstance(text, bytes) else text.encode())
    return folder


def test_the_file_sets_the_start_values_and_reset_restores_them(tmp_path: Path) -> None:
    text = "# the system's values\nname,value\nkp[2],123.5\r\nf[1,2],0.25\n\nfeedforward,false\n"
    with Slave("controller", unzip_dir=copy_with(tmp_path, "controller", text)) as s:
        s.instantiate().to_step_mode()
        assert s.get(["kp[2]", "f[1,2]"]) == [123.5, 0.25]
        assert s.fmu.getBoolean([s.vr["feedforward"]]) == [False]
        s.fmu.reset()
        s.set({"kp[2]": 7.0})
        s.to_step_mode()
        assert s.get(["kp[2]"]) == [7.0]
        s.fmu.reset()
        s.to_step_mode()
        assert s.get(["kp[2]"]) == [123.5]  # the file's again, not the compiled 100
        assert s.errors() == []
    with Slave("controller") as plain:  # no file: the compiled values
        plain.instantiate().to_step_mode()
        assert plain.get(["kp[2]"]) == [100.0]


@pytest.mark.parametrize(("text", "message"), [
    ("kp[2],1\n", "line 1: the header name,value expected"),
    ("name,value\nkp[2]\n", "line 2: expected name,value"),
    ("name,value\nkq[2],1\n", 'has no parameter or input "kq[2]"'),
    ("name,value\nu[1],1\n", 'has no parameter or input "u[1]"'),  # an output
    ("name,value\nkp[2],fast\n", 'kp[2]: a number expected, got "fast"'),
    ("name,value\nkp[2],1.5x\n", "a number expected"),
    ("name,value\nkp[2],nan\n", "must be finite"),
    ("name,value\nkp[2],1e999\n", "must be finite"),
    ("name,value\nfeedforward,yes\n", "true or false expected"),
    ("name,value\n" + "kp[2]," + "1" * 300 + "\n", "longer than 256 characters"),
    (b"name,value\nkp[2],1\x00\n", "not text"),
    ("name,value\n" + "# padding\n" * 7000, "larger than 65536 bytes"),
])
def test_a_malformed_file_stops_the_instantiation(tmp_path: Path, text: str | bytes,
                                                  message: str) -> None:
    with Slave("controller", unzip_dir=copy_with(tmp_path, "controller", text)) as s:
        with pytest.raises(Exception, match="instantiate"):
            s.instantiate()
        errors = s.errors()
        assert any(message in e and "start_values.csv" in e for e in errors), errors


def test_the_plant_starts_where_the_file_says(tmp_path: Path) -> None:
    text = "name,value\nq0[2],0.5\nqd0[3],-0.25\n"
    with Slave("plant", unzip_dir=copy_with(tmp_path, "plant", text)) as s:
        s.instantiate().to_step_mode()
        assert s.get(["q[2]", "qd[3]"]) == [0.5, -0.25]
