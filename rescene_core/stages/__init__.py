"""The stages of ReScene as units: one body per stage (a module each), their declaration (``dag``), the
library calls they make (``calls``), what a body needs when it runs (``execution``) and code versions
from the import closure (``version``). The Prefect tasks (tasks/) and the in-process pipeline
(``rescene_core.pipeline``) both run these bodies, in the order of ``dag.DAG``."""
