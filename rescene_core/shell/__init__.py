"""Room shell: floor plane, vertical walls and floor polygon from a capture."""

from rescene_core.shell.estimate import ShellError, estimate_shell
from rescene_core.shell.io import load_shell, plot_shell, save_shell

__all__ = ["ShellError", "estimate_shell", "load_shell", "plot_shell", "save_shell"]
