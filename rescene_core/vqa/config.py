"""Configuration of embodied VQA generation: ``VqaConfig`` lives in ``rescene_core.config`` (``RunConfig.vqa``,
so ``--set vqa.field=value`` and config.yaml reach it); it is re-exported here."""

from rescene_core.config import VqaConfig

__all__ = ["VqaConfig"]
