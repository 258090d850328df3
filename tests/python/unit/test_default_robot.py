"""The default robot: the TOML shipped with the package and the C defaults agree."""

from __future__ import annotations

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core.model import DEFAULT_ROBOT_TOML


def test_toml_equals_c_defaults() -> None:
    from_c = rr.Model.default()
    from_file = rr.read_robot_file(DEFAULT_ROBOT_TOML).model
    assert from_c.dh == from_file.dh
    assert from_c.g == from_file.g
    np.testing.assert_allclose(from_file.p, from_c.p, rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(from_file.kt, from_c.kt)
    np.testing.assert_array_equal(from_file.f, from_c.f)
    np.testing.assert_array_equal(from_file.w, from_c.w)
    np.testing.assert_array_equal(from_file.b, from_c.b)
    assert from_file.u_max == from_c.u_max


def test_round_trip_through_toml(tmp_path) -> None:
    m = rr.Model.default().with_params(kt=[5.0, 11.0, 4.0])
    path = tmp_path / "robot.toml"
    m.to_toml(path)
    back = rr.read_robot_file(path).model
    np.testing.assert_array_equal(back.p, m.p)
    np.testing.assert_array_equal(back.kt, m.kt)
    assert back.dh == m.dh


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[kinematics]\nd1 = 0.5\n", "missing key 'a2' in [kinematics]"),
        ("not toml at all [", "not valid TOML"),
        ("", "missing table [kinematics]"),
    ],
)
def test_bad_robot_files(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(rr.ModelError, match=message.replace("[", r"\[").replace("]", r"\]")):
        rr.read_robot_file(path)


def test_bad_values_name_the_field(tmp_path) -> None:
    src = DEFAULT_ROBOT_TOML.read_text()
    cases = {
        "kt = [12.0, 11.0, 4.7]": ("kt = [12.0, 0.0, 4.7]", "kt\\[2\\]"),
        "a3 = 0.35": ("a3 = nan", r"\[kinematics\] a3 must be a finite number > 0.*got nan"),
        "mass = 6.0": ("mass = -6.0", r"\[link2\] mass must be a finite number > 0"),
        "u_max = 10.0": ("u_max = [1, 2]", r"\[motors\] u_max must be a finite number > 0.*"
                         r"got \[1, 2\]"),
        "d1 = 0.50": ("d1 = true", r"\[kinematics\] d1 must be a finite number.*got true"),
        "b = [0.02, 0.02, 0.02]": ('b = [0.02, "0.02", 0.02]',
                                   r'\[friction\] b\[2\] must be a finite number >= 0.*got "0.02"'),
    }
    for old, (new, message) in cases.items():
        assert old in src
        path = tmp_path / "bad.toml"
        path.write_text(src.replace(old, new, 1))
        with pytest.raises(rr.ModelError, match=message):
            rr.read_robot_file(path)
    with pytest.raises(rr.ModelError, match="does not exist"):
        rr.read_robot_file(tmp_path / "missing.toml")


def test_with_params_validates() -> None:
    m = rr.Model.default()
    with pytest.raises(rr.ModelError, match="p"):
        m.with_params(p=np.zeros(16))
    with pytest.raises(rr.BadInputError, match="unknown model parameter"):
        m.with_params(mass=3.0)
    with pytest.raises(rr.BadInputError, match="shape"):
        m.with_params(kt=[1.0, 2.0])
