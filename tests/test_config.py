"""RunConfig: nested sections, --set and config.yaml reaching nested fields, and where each default comes from."""

import pytest
import yaml
from pydantic import BaseModel, ValidationError

from rescene_core.config import (
    AssetConfig,
    ExportConfig,
    FusionConfig,
    LiftConfig,
    RunConfig,
    SceneGraphConfig,
    VlmClientConfig,
    VqaConfig,
    load_config,
)


def _sections(model: type[BaseModel]):
    yield model
    for info in model.model_fields.values():
        if isinstance(info.annotation, type) and issubclass(info.annotation, BaseModel):
            yield from _sections(info.annotation)


def test_run_config_holds_every_section_nested():
    config = RunConfig()
    assert isinstance(config.assets.lift, LiftConfig)
    assert isinstance(config.scenegraph.vlm, VlmClientConfig)
    assert isinstance(config.scenegraph.fusion, FusionConfig)
    assert isinstance(config.export, ExportConfig) and isinstance(config.vqa, VqaConfig)
    assert config.vqa.min_confidence == config.scenegraph.fusion.low_confidence


def test_every_field_says_whose_default_it_is():
    missing = []
    for section in _sections(RunConfig):
        if section is RunConfig:
            continue
        for name, info in section.model_fields.items():
            if isinstance(info.annotation, type) and issubclass(info.annotation, BaseModel):
                continue
            text = info.description or ""
            if (
                "Default: the paper's" not in text
                and "Default: the project's" not in text
                and ("Default: HierView's" not in text)
            ):
                missing.append(f"{section.__name__}.{name}")
    assert not missing, missing


def test_paper_tables_are_the_defaults():
    config = RunConfig()
    assert (config.registration.scale_min, config.registration.scale_max) == (0.90, 1.10)
    assert config.hierview.tau_s == 0.12
    fusion = config.scenegraph.fusion
    assert (fusion.alpha, fusion.beta, fusion.gamma, fusion.shell_weight) == (0.60, 0.25, 0.15, 0.15)
    assert (config.scenegraph.vlm.retry_budget, config.scenegraph.vlm.min_id_coverage) == (2, 0.95)


def test_set_reaches_nested_fields():
    config = load_config(
        None,
        [
            "scenegraph.vlm.base_url=http://gpu:8000/v1",
            "scenegraph.fusion.alpha=0.5",
            "assets.lift.resolution=48",
            "export.wall_height=3.0",
            "vqa.seed=7",
            "registration.seed=2",
        ],
    )
    assert config.scenegraph.vlm.base_url == "http://gpu:8000/v1"
    assert config.scenegraph.fusion.alpha == 0.5
    assert config.assets.lift.resolution == 48
    assert config.export.wall_height == 3.0 and config.vqa.seed == 7 and config.registration.seed == 2
    assert config.scenegraph.fusion.beta == FusionConfig().beta


@pytest.mark.parametrize(
    ("item", "words"),
    [
        ("scenegraph.base_url=http://x", "has no setting 'base_url'"),
        ("nope.x=1", "'nope' is not one of the sections"),
        ("assets.lift=3", "is a group of settings"),
        ("assets.lift.nope=3", "has no setting 'nope'"),
        ("resolution=3", "expects section.field=value"),
    ],
)
def test_set_rejects_unknown_settings_clearly(item, words):
    with pytest.raises(ValueError, match=words):
        load_config(None, [item])


def test_set_values_are_validated():
    with pytest.raises(ValidationError):
        load_config(None, ["assets.lift.resolution=many"])


def test_config_yaml_reaches_nested_fields(tmp_path):
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump({"assets": {"lift": {"mirror": False}}, "scenegraph": {"vlm": {"timeout_s": 5}}}))
    config = load_config(path, ["assets.lift.resolution=32"])
    assert config.assets.lift.mirror is False and config.assets.lift.resolution == 32
    assert config.scenegraph.vlm.timeout_s == 5.0
    flat = tmp_path / "flat.yaml"
    flat.write_text(yaml.safe_dump({"assets": {"lift_resolution": 32}}))
    with pytest.raises(ValidationError, match="lift_resolution"):
        load_config(flat)


def test_a_dumped_config_loads_back_identically(tmp_path):
    config = load_config(None, ["assets.lift.join_cells=0", "scenegraph.geometric.wall_tol=0.1"])
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config.model_dump(mode="json")))
    assert load_config(path) == config


def test_api_key_is_never_dumped():
    config = SceneGraphConfig(vlm=VlmClientConfig(api_key="sk-secret"))
    assert "sk-secret" not in str(config.model_dump()) and "sk-secret" not in repr(config)
    assert RunConfig(scenegraph=config).section_hash("scenegraph") == RunConfig().section_hash("scenegraph")


def test_section_hash_follows_nested_changes():
    base = RunConfig()
    changed = RunConfig(assets=AssetConfig(lift=LiftConfig(resolution=41)))
    assert base.section_hash("assets") != changed.section_hash("assets")
    assert base.section_hash("registration") == changed.section_hash("registration")
