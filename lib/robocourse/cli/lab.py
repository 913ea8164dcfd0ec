"""``robocourse lab-settings``: the course's JupyterLab set-up, written into the venv (``make lab``).

What a student sees when ``make lab`` opens the browser:

- the server root is the course folder, so the file browser lists ``chapters/`` and
  ``exercises/`` side by side (and the library, for reading); the default workspace opens
  ``chapters/00_setup_check.ipynb`` with its exercise notebook split to the right;
- the "Python (robocourse)" kernel is the server's default kernel, and a new notebook starts it
  without the kernel-selection dialog (``autoStartDefaultKernel``);
- JupyterLab's "get notified about official Jupyter news?" toast and its update check are off
  (``@jupyterlab/apputils-extension:notification``: ``fetchNews: "false"``,
  ``checkForUpdates: false``);
- kernels talk to the server over IPC sockets (``KernelManager.transport = "ipc"``), files in
  Jupyter's runtime folder that only this user can open, instead of TCP on loopback, which any
  local user can connect to: the kernel's "Kernel is running over TCP without encryption"
  warning no longer starts every session. A Unix socket path is limited to 107 bytes; when the
  runtime folder is too deep for that, the lab keeps TCP and ``lab-settings`` says why.

Everything goes under the venv's prefix (JupyterLab's *application* settings
``<prefix>/share/jupyter/lab/settings/overrides.json``, the server config
``<prefix>/etc/jupyter/jupyter_server_config.d/robocourse.json`` and the workspaces folder
``<prefix>/share/jupyter/lab/workspaces``), never in the user's home: overrides only change
defaults, so a student's own choices in ``~/.jupyter/lab/user-settings`` still win.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

KERNEL = "robocourse"
FIRST_CHAPTER = "chapters/00_setup_check.ipynb"
FIRST_EXERCISE = "exercises/00_setup_exercises.ipynb"
NOTIFICATION_PLUGIN = "@jupyterlab/apputils-extension:notification"
NOTEBOOK_PLUGIN = "@jupyterlab/notebook-extension:tracker"

# The plugin ids and keys below are checked against the installed JupyterLab's schemas
# (``<prefix>/share/jupyter/lab/schemas/...``) before anything is written: a renamed setting
# is an error, not a silently ignored override.
OVERRIDES = {
    NOTIFICATION_PLUGIN: {"fetchNews": "false", "checkForUpdates": False},
    NOTEBOOK_PLUGIN: {"autoStartDefaultKernel": True},
}


def overrides_path(prefix: Path) -> Path:
    return prefix / "share/jupyter/lab/settings/overrides.json"


def server_config_path(prefix: Path) -> Path:
    return prefix / "etc/jupyter/jupyter_server_config.json"


def workspaces_dir(prefix: Path) -> Path:
    return prefix / "share/jupyter/lab/workspaces"


#: the longest socket path a kernel makes: <runtime>/kernel-<36-char uuid>-ipc-<port>
_IPC_SUFFIX = len("/kernel-00000000-0000-0000-0000-000000000000-ipc-65535")
_SUN_PATH_MAX = 107


def ipc_transport_fits(runtime_dir: str | None = None) -> tuple[bool, str]:
    """Can kernels use IPC sockets in Jupyter's runtime folder (a Unix socket path is at most 107 bytes)?"""
    if runtime_dir is None:
        from jupyter_core.paths import jupyter_runtime_dir

        runtime_dir = jupyter_runtime_dir()
    longest = len(os.fsencode(runtime_dir)) + _IPC_SUFFIX
    if sys.platform == "win32":
        return False, "Windows has no IPC transport for Jupyter kernels: they use TCP on loopback"
    if longest > _SUN_PATH_MAX:
        return False, (f"kernel sockets in {runtime_dir} would be {longest} bytes long, over the {_SUN_PATH_MAX} a "
                       "Unix socket path allows: kernels use TCP on loopback (the kernel warns about it); set "
                       "JUPYTER_RUNTIME_DIR to a shorter folder, e.g. /tmp/jupyter-$USER, and run make lab again")
    return True, ""


def server_config(root: Path, prefix: Path, ipc: bool = True) -> dict:
    """jupyter_server config: course folder as root, course kernel as default, workspaces in the venv,
    kernels over IPC (``ipc=False``: TCP)."""
    config = {
        "ServerApp": {"root_dir": str(root.resolve())},
        "MappingKernelManager": {"default_kernel_name": KERNEL},
        "LabApp": {"workspaces_dir": str(workspaces_dir(prefix).resolve())},
    }
    if ipc:
        config["KernelManager"] = {"transport": "ipc"}
    return config


def default_workspace(root: Path) -> dict:
    """The ``default`` workspace: the first chapter, its exercise to the right, files at the root."""
    opened = [p for p in (FIRST_CHAPTER, FIRST_EXERCISE) if (root / p).is_file()]
    areas = [{"type": "tab-area", "currentIndex": 0, "widgets": [f"notebook:{p}"]} for p in opened]
    if len(areas) > 1:
        dock = {"type": "split-area", "orientation": "horizontal", "sizes": [0.5, 0.5], "children": areas}
    else:
        dock = areas[0] if areas else None
    data = {
        "layout-restorer:data": {
            "main": {"dock": dock, "current": f"notebook:{opened[0]}" if opened else None},
            "left": {"collapsed": False, "visible": True, "current": "filebrowser",
                     "widgets": ["filebrowser", "running-sessions", "@jupyterlab/toc:plugin"]},
            "right": {"collapsed": True, "visible": True, "widgets": []},
            "relativeSizes": [0.16, 0.84, 0],
        },
        "file-browser-filebrowser:cwd": {"path": ""},
    }
    for p in opened:
        data[f"notebook:{p}"] = {"data": {"path": p, "factory": "Notebook"}}
    return {"data": data, "metadata": {"id": "/default"}}


def check_overrides_against_schemas(prefix: Path, overrides: dict = OVERRIDES) -> None:
    """Refuse an override whose plugin or key the installed JupyterLab does not define."""
    schemas = prefix / "share/jupyter/lab/schemas"
    if not schemas.is_dir():
        raise FileNotFoundError(f"{schemas} not found: JupyterLab is not installed in {prefix}; "
                                "run `make setup` first")
    for plugin, values in overrides.items():
        package, _, name = plugin.partition(":")
        schema_file = schemas / package / f"{name}.json"
        if not schema_file.is_file():
            raise KeyError(f"setting plugin {plugin!r} not found ({schema_file} missing): "
                           "this JupyterLab renamed it; update robocourse.cli.lab.OVERRIDES")
        properties = json.loads(schema_file.read_text(encoding="utf-8"))["properties"]
        for key, value in values.items():
            if key not in properties:
                raise KeyError(f"{plugin} has no setting {key!r} (it has {sorted(properties)}); "
                               "update robocourse.cli.lab.OVERRIDES")
            allowed = [c["const"] for c in properties[key].get("oneOf", []) if "const" in c]
            kind = {"boolean": bool, "string": str}.get(properties[key].get("type"))
            if (allowed and value not in allowed) or (kind and not isinstance(value, kind)):
                raise ValueError(f"{plugin}: {key}={value!r} is not a value this JupyterLab accepts "
                                 f"({allowed or properties[key].get('type')}); update robocourse.cli.lab.OVERRIDES")


def _write_json(path: Path, data: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    return path


def write_default_workspace(folder: Path, root: Path, reset: bool = False) -> Path | None:
    """Save the course's ``default`` workspace in ``folder`` unless one is there (or ``reset``)."""
    from jupyterlab_server.workspaces_handler import WorkspacesManager

    manager = WorkspacesManager(str(folder))
    try:
        have_default = bool(manager.load("default")["data"])  # {} when there is none yet
    except ValueError:  # an unreadable saved layout: replace it
        have_default = False
    if reset or not have_default:
        return manager.save("default", json.dumps(default_workspace(Path(root))))
    return None


def write_settings(root: Path | str = ".", prefix: Path | str = sys.prefix, reset_workspace: bool = False) -> list[Path]:
    """Write the lab settings into ``prefix``; return the files written.

    The default workspace is written only when missing (or with ``reset_workspace``): once the
    student rearranges the lab, JupyterLab saves their layout in the same file and it is kept.
    """
    root, prefix = Path(root), Path(prefix)
    check_overrides_against_schemas(prefix)
    overrides = overrides_path(prefix)
    existing = json.loads(overrides.read_text(encoding="utf-8")) if overrides.is_file() else {}
    for plugin, values in OVERRIDES.items():
        existing.setdefault(plugin, {}).update(values)
    ipc, why = ipc_transport_fits()
    if not ipc:
        print(f"note: {why}", file=sys.stderr)
    written = [_write_json(overrides, existing),
               _write_json(server_config_path(prefix), server_config(root, prefix, ipc=ipc))]
    workspace = write_default_workspace(workspaces_dir(prefix), root, reset_workspace)
    return written + ([workspace] if workspace else [])


def register(sub):
    p = sub.add_parser("lab-settings", help="write the course's JupyterLab settings into a venv (make lab runs it)")
    p.add_argument("--root", default=".", help="course folder the lab opens (default: .)")
    p.add_argument("--prefix", default=sys.prefix, help=f"venv to write into (default: this Python's, {sys.prefix})")
    p.add_argument("--reset-workspace", action="store_true",
                   help="replace the saved default layout with the course's (first chapter + its exercise)")
    p.set_defaults(func=run)


def run(args) -> int:
    for path in write_settings(args.root, args.prefix, args.reset_workspace):
        print(f"wrote {path}")
    return 0
