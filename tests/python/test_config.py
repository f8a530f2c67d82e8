# SPDX-License-Identifier: Apache-2.0
"""The config validator: the default loads; every kind of bad file is a
ConfigError naming the key, never another exception."""

import copy
import json
from pathlib import Path

import pytest

from stewart import config as cfg
import gen_platform

REPO_ROOT = Path(__file__).resolve().parents[2]

DEFAULT = REPO_ROOT / "config" / "platform_default.json"


def base():
    return json.loads(DEFAULT.read_text())


def test_default_loads_and_quantizes():
    p = cfg.load(DEFAULT)
    assert p.mass == 2500.0 and len(p.base_joints) == 6
    q = gen_platform.quantize(p)
    assert q["home"][2] == round(2.55 * (1 << 24))
    assert q["force_max"] == 120000 * 256


def mutate(path, value):
    d = base()
    node = d
    for k in path[:-1]:
        node = node[k]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return d


@pytest.mark.parametrize("path,value,needle", [
    (("mass",), KeyError, "mass: missing"),
    (("base_joints",), [[0, 0, 0]] * 5, "base_joints"),
    (("platform_joints", 2), [0, 0], "platform_joints[2]"),
    (("mass",), -1.0, "mass: must be positive"),
    (("mass",), "heavy", "mass: expected a number"),
    (("mass",), 1e9, "mass"),
    (("inertia", 0, 1), 5.0, "inertia: must be symmetric"),
    (("inertia",), [[1, 0, 0], [0, 1, 0], [0, 0, 5]], "triangle"),
    (("leg_length_max",), 1.0, "leg_length_max"),
    (("leg_length_min",), 2.6, "home: leg 1"),
    (("home",), [0, 0, 4.0, 0, 0, 0], "home: leg"),
    (("workspace", "min", 0), 0.1, "workspace"),
    (("hydraulic", "rod_diameter"), 0.2, "hydraulic.rod_diameter"),
    (("hydraulic", "bulk_modulus"), KeyError, "hydraulic.bulk_modulus: missing"),
    (("sensors", "seed"), -3, "sensors.seed"),
    (("gravity",), float("nan"), "gravity"),
    (("estop", "category"), 2, "estop.category"),
    (("estop", "category"), True, "estop.category"),
    (("estop", "deceleration"), 0.05, "estop.deceleration"),
    (("estop", "angular_jerk"), 1000.0, "estop.angular_jerk"),
    (("estop", "settle"), -0.1, "estop.settle"),
    (("estop", "brake"), 1.0, "estop.brake: unknown key"),
])
def test_bad_values_name_the_key(tmp_path, path, value, needle):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(mutate(path, value)))
    with pytest.raises(cfg.ConfigError) as e:
        cfg.load(f)
    assert needle in str(e.value)
    assert "bad.json" in str(e.value)


@pytest.mark.parametrize("text,needle", [
    ("{ not json", "not valid JSON"),
    ("[1, 2]", "top level"),
    ("", "not valid JSON"),
])
def test_unparseable_files(tmp_path, text, needle):
    f = tmp_path / "bad.json"
    f.write_text(text)
    with pytest.raises(cfg.ConfigError, match=needle):
        cfg.load(f)


def test_missing_file(tmp_path):
    with pytest.raises(cfg.ConfigError, match="cannot read"):
        cfg.load(tmp_path / "nope.json")


def test_generator_fails_the_build_with_the_message(tmp_path, capsys):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(mutate(("mass",), KeyError)))
    assert gen_platform.main([str(f), str(tmp_path / "out.c")]) == 1
    assert "mass: missing" in capsys.readouterr().err
    assert not (tmp_path / "out.c").exists()


def test_generator_writes_c(tmp_path):
    out = tmp_path / "p.c"
    assert gen_platform.main([str(DEFAULT), str(out)]) == 0
    text = out.read_text()
    assert "const sp_platform_t sp_platform_default" in text
    assert str(round(2.55 * (1 << 24))) in text


def test_fuzzed_configs_never_crash(tmp_path):
    import random

    rnd = random.Random(5)
    d0 = base()
    keys = list(d0.keys())
    junk = [None, "x", -1, 0, 1e300, [], {}, [1, 2, 3], True]
    for i in range(300):
        d = copy.deepcopy(d0)
        for _ in range(rnd.randint(1, 3)):
            k = rnd.choice(keys)
            d[k] = rnd.choice(junk)
        try:
            cfg.from_dict(d, "fuzz")
        except cfg.ConfigError:
            pass


def test_estop_section_generated(tmp_path):
    """The estop section reaches the firmware's sp_estop_default (Q24, settle
    in 1 ms ticks); absent, the defaults (category 1)."""
    d = mutate(("estop",), {"category": 0, "deceleration": 2.5, "jerk": 40.0, "settle": 0.05})
    f = tmp_path / "p.json"
    f.write_text(json.dumps(d))
    p = cfg.load(f)
    assert p.estop == {"category": 0, "deceleration": 2.5, "angular_deceleration": 4.0, "jerk": 40.0,
                       "angular_jerk": 25.0, "settle": 0.05}
    out = tmp_path / "p.c"
    assert gen_platform.main([str(f), str(out)]) == 0
    assert ("const sp_estop_config_t sp_estop_default = {0u, {{41943040, 67108864}, {671088640, 419430400}}, 50u};"
            in out.read_text())
    del d["estop"]
    f.write_text(json.dumps(d))
    assert cfg.load(f).estop == cfg.ESTOP_DEFAULT
