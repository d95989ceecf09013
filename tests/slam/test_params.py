import pytest

from common.config import ConfigError
from master_side.slam.params import GMappingParams, load_gmapping


def test_the_p3at_gmapping_yaml_loads_unchanged(shared_dir):
    p = load_gmapping(shared_dir / "reference" / "p3at" / "gmapping.yaml")
    assert p.str_ == 0.01
    assert p.srt == 0.02
    assert p.particles == 300
    assert p.maxUrange == 6.0
    assert p.minimumScore == 200.0
    assert p.temporalUpdate == -1.0


def test_unknown_keys_and_bad_values_are_rejected(tmp_path):
    (tmp_path / "g.yaml").write_text("particels: 3\n")
    with pytest.raises(ConfigError, match="particels"):
        load_gmapping(tmp_path / "g.yaml")
    with pytest.raises(ConfigError, match="delta"):
        load_gmapping(None, delta=-1.0)
    assert GMappingParams().particles == 30
