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
    for k in LEG_KEYS:
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
