# SPDX-License-Identifier: Apache-2.0
"""Optional leg masses in the config's hydraulic section (issue 5): absent
means 0 (off; the default config sets them); bad values are a ConfigError naming the key; gen_plant.py
writes them into hs_config_default."""

import json
from pathlib import Path

import pytest

from stewart import config as cfg
import gen_plant

REPO_ROOT = Path(__file__).resolve().parents[2]

DEFAULT = REPO_ROOT / "config" / "platform_default.json"
LEG_KEYS = ("cylinder_mass", "cylinder_com", "rod_mass", "rod_com")


def with_hydraulic(**extra):
    d = json.loads(DEFAULT.read_text())
    d["hydraulic"].update(extra)
    return d


def test_absent_means_zero(tmp_path):
    d = json.loads(DEFAULT.read_text())
    for k in LEG_KEYS + ("cylinder_inertia", "rod_inertia"):
        d["hydraulic"].pop(k, None)
    f = tmp_path / "massless.json"
    f.write_text(json.dumps(d))
    p = cfg.load(f)
    assert all(p.hydraulic[k] == 0.0 for k in LEG_KEYS)
    text = gen_plant.c_source(p)
    for k in LEG_KEYS:
        assert f".{k} = 0.0," in text


def test_values_reach_the_generated_c(tmp_path):
    f = tmp_path / "legs.json"
    f.write_text(json.dumps(with_hydraulic(cylinder_mass=60.0, cylinder_com=0.8, rod_mass=35.0, rod_com=1.0)))
    out = tmp_path / "plant.c"
    assert gen_plant.main([str(f), str(out)]) == 0
    text = out.read_text()
    for k, v in (("cylinder_mass", "60.0"), ("cylinder_com", "0.8"), ("rod_mass", "35.0"), ("rod_com", "1.0")):
        assert f".{k} = {v}," in text


@pytest.mark.parametrize("key,value,needle", [
    ("cylinder_mass", -1.0, "hydraulic.cylinder_mass"),
    ("rod_mass", "heavy", "hydraulic.rod_mass: expected a number"),
    ("rod_mass", 1e5, "hydraulic.rod_mass"),
    ("cylinder_com", -0.1, "hydraulic.cylinder_com"),
    ("rod_com", 4.0, "hydraulic.rod_com: 4 m is beyond leg_length_max"),
    ("cylinder_com", float("nan"), "hydraulic.cylinder_com"),
])
def test_bad_leg_values_name_the_key(tmp_path, key, value, needle):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(with_hydraulic(**{key: value})))
    with pytest.raises(cfg.ConfigError) as e:
        cfg.load(f)
    assert needle in str(e.value)
    assert "bad.json" in str(e.value)


INERTIA_KEYS = ("cylinder_inertia", "rod_inertia")


def test_leg_inertia_absent_means_zero_and_reaches_the_generated_c(tmp_path):
    """The legs' moments of inertia across the leg: absent = 0 (point
    masses), set values reach the plant's and the firmware's generated C
    (the firmware's in Q16)."""
    import gen_platform

    d = json.loads(DEFAULT.read_text())
    for k in INERTIA_KEYS:
        d["hydraulic"].pop(k, None)
    p = cfg.from_dict(d, "point.json")
    assert all(p.hydraulic[k] == 0.0 for k in INERTIA_KEYS)
    f = tmp_path / "spun.json"
    f.write_text(json.dumps(with_hydraulic(cylinder_inertia=11.25, rod_inertia=7.5)))
    p = cfg.load(f)
    plant_c = gen_plant.c_source(p)
    assert ".cylinder_inertia = 11.25," in plant_c and ".rod_inertia = 7.5," in plant_c
    firmware_c = gen_platform.c_source(p)
    assert f"{round(11.25 * 65536)}, {round(7.5 * 65536)}}}," in firmware_c


@pytest.mark.parametrize("extra,needle", [
    ({"cylinder_inertia": -0.5}, "hydraulic.cylinder_inertia"),
    ({"rod_inertia": float("inf")}, "hydraulic.rod_inertia"),
    ({"rod_inertia": "big"}, "hydraulic.rod_inertia: expected a number"),
    ({"cylinder_inertia": 1e5}, "hydraulic.cylinder_inertia"),
    ({"rod_mass": 0.0, "rod_inertia": 2.0}, "hydraulic.rod_inertia: 2 kg m^2 but rod_mass is 0"),
    # 60 kg no longer than 3.25 m: at most 60 (3.25^2 / 4 + 1/4) = 173 kg m^2
    ({"cylinder_inertia": 180.0}, "hydraulic.cylinder_inertia: 180 kg m^2 is more than a 60 kg body"),
])
def test_bad_leg_inertia_names_the_key(tmp_path, extra, needle):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(with_hydraulic(**extra)))
    with pytest.raises(cfg.ConfigError) as e:
        cfg.load(f)
    assert needle in str(e.value)
    assert "bad.json" in str(e.value)


def test_leg_inertia_at_the_plausible_limit_is_accepted(tmp_path):
    f = tmp_path / "edge.json"
    f.write_text(json.dumps(with_hydraulic(cylinder_inertia=173.0, rod_inertia=0.0)))
    assert cfg.load(f).hydraulic["cylinder_inertia"] == 173.0
