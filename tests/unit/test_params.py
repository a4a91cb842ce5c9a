"""Parameter records and files: bad input fails with the file, the field and what is allowed."""

import math

import numpy as np
import pytest

import exoleg
from exoleg import ParameterError
from exoleg.params import paper

GOOD = """
g = 9.81
[[link]]
name = "thigh"
length = 0.30
mass = 2.0
com = [0.12, 0.0]
izz = 0.02
[[link]]
name = "shank"
length = 0.32
mass = 1.5
com = [0.13, 0.0]
izz = 0.01
[[link]]
name = "foot"
length = 0.2
mass = 0.8
com = [0.05, -0.02]
izz = 0.001
"""


def write(tmp_path, text):
    p = tmp_path / "leg.toml"
    p.write_text(text)
    return p


def test_good_file_loads(tmp_path):
    leg = exoleg.load_leg(write(tmp_path, GOOD))
    assert leg.links[2].com == (0.05, -0.02)


@pytest.mark.parametrize("old,new,field,allowed", [
    ("mass = 1.5", "", "mass", "missing"),
    ("mass = 1.5", "mass = -1.5", "mass", "must be > 0"),
    ("mass = 1.5", "mass = 0.0", "mass", "must be > 0"),
    ("izz = 0.01", "izz = nan", "izz", "finite"),
    ("izz = 0.01", "izz = -0.01", "izz", "must be > 0"),
    ("izz = 0.01", "izz = 0.01\nwidth = 3", "width", "unknown field"),
    ("com = [0.13, 0.0]", "com = [0.13]", "com", "expected 2 numbers"),
    ("length = 0.32", "length = inf", "length", "finite"),
])
def test_bad_field_names_file_field_and_rule(tmp_path, old, new, field, allowed):
    text = GOOD.split("[[link]]")  # edit the second link (shank)
    text[2] = text[2].replace(old, new)
    p = write(tmp_path, "[[link]]".join(text))
    with pytest.raises(ParameterError) as e:
        exoleg.load_leg(p)
    msg = str(e.value)
    assert str(p) in msg and "link[1]" in msg and field in msg and allowed in msg


def test_wrong_link_count_and_syntax(tmp_path):
    with pytest.raises(ParameterError, match="exactly 3"):
        exoleg.load_leg(write(tmp_path, GOOD.split("[[link]]\nname = \"foot\"")[0]))
    with pytest.raises(ParameterError, match="not valid TOML"):
        exoleg.load_leg(write(tmp_path, "g = = 1"))
    with pytest.raises(ParameterError, match="no such file"):
        exoleg.load_leg(tmp_path / "absent.toml")


def test_round_trip_is_exact(tmp_path):
    for variant in ("simplified", "detailed"):
        leg = exoleg.paper_leg(variant)
        back = exoleg.load_leg(exoleg.save_leg(leg, tmp_path / f"{variant}.toml"))
        assert np.array_equal(back.p, leg.p)
        assert back.has_parts == leg.has_parts


def test_link_rejects_parts_that_do_not_compose():
    d = exoleg.paper_leg("detailed").links[0]
    with pytest.raises(ParameterError, match="parts"):
        exoleg.Link(mass=d.mass * 1.1, length=d.length, com=d.com, izz=d.izz, parts=d.parts)


def test_paper_tables_load_in_si():
    acts = paper.actuators()
    assert [a.max_torque for a in acts] == [150.0, 70.0, 168.0]  # Table 2
    assert acts[1].max_velocity == pytest.approx(math.radians(720))
    gains = paper.controller_gains()
    assert list(gains.kp) == [80, 80, 50] and list(gains.kd) == [12, 12, 2]  # Fig. 12
    rom = paper.range_of_motion()
    assert np.degrees(rom.upper[0]) == pytest.approx(90.0)  # swapped hip reading, see file
    # Table 5 COM rows are mislabelled; link 3's (lcx, lcy) are rows 7-8.
    foot = paper.table5_links("simplified")[2]
    assert foot.com == pytest.approx((0.235 / 2 - 0.086892122966857, -0.029380769989573))


def test_model_input_errors_name_the_joint():
    leg = exoleg.paper_leg()
    with pytest.raises(ParameterError, match=r"q.*shape \(3,\)"):
        leg.M([0.0, 0.0])
    with pytest.raises(ParameterError, match="knee is nan"):
        leg.G([0.0, float("nan"), 0.0])
    with pytest.raises(ParameterError, match="tau"):
        leg.forward_dynamics([0, 0, 0], [0, 0, 0], [0, np.inf, 0])
    with pytest.raises(ParameterError, match="exactly 3 links"):
        exoleg.LegModel(leg.links[:2])
    with pytest.raises(ParameterError, match="variant"):
        exoleg.paper_leg("fancy")  # type: ignore[arg-type]


def test_a_parameter_error_crosses_processes_whole() -> None:
    # a study's workers and process pools send errors back pickled
    import pickle

    from exoleg.errors import ParameterError

    e = pickle.loads(pickle.dumps(ParameterError("s.toml", "axes.age", "30 is outside 2-20")))
    assert (e.where, e.field, e.problem) == ("s.toml", "axes.age", "30 is outside 2-20")
    assert str(e) == "s.toml: axes.age: 30 is outside 2-20"
