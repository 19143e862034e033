"""Run configuration: one pydantic model per stage, defaults = the paper's appendix tables where it has them.

``RunConfig`` is the single parameter of the flow. Sections nest (``assets.lift``, ``scenegraph.vlm`` /
``geometric`` / ``fusion``); ``--set section.sub.field=value`` and config.yaml reach every level. Each
field's docstring ends by saying whose default it is: "Default: the paper's (<table or appendix>)" or
"Default: the project's choice" (tests/test_config.py checks every field). Sections are hashed separately
(``section_hash``) so a changed registration parameter invalidates registration and what follows it,
and nothing before it.
"""

from rescene_core.config.attachment import AttachmentConfig
from rescene_core.config.capture import HierViewConfig, KeyFrameConfig, ShellConfig
from rescene_core.config.objects import AssetConfig, LiftConfig, RegistrationConfig
from rescene_core.config.outputs import ExportConfig, SimcheckConfig, VqaConfig
from rescene_core.config.run import RunConfig, load_config
from rescene_core.config.scenegraph import FusionConfig, GeometricConfig, SceneGraphConfig, VlmClientConfig

__all__ = [
    "AssetConfig",
    "AttachmentConfig",
    "ExportConfig",
    "FusionConfig",
    "GeometricConfig",
    "HierViewConfig",
    "KeyFrameConfig",
    "LiftConfig",
    "RegistrationConfig",
    "RunConfig",
    "SceneGraphConfig",
    "ShellConfig",
    "SimcheckConfig",
    "VlmClientConfig",
    "VqaConfig",
    "load_config",
]
