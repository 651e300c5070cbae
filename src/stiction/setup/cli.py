"""`stiction udev`, `stiction service` and `stiction doctor`: running as a normal user."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from stiction.errors import StictionError

RULES_DIR = Path("/etc/udev/rules.d")
RELOAD_UDEV = "sudo udevadm control --reload && sudo udevadm trigger"


def _default_rules_path() -> Path:
    from stiction.setup.udev_rules import RULES_NAME

    return RULES_DIR / RULES_NAME


def _udev_print(args: argparse.Namespace) -> int:
    from stiction.setup.udev_rules import builtin_rules

    sys.stdout.write(builtin_rules())
    return 0


def _udev_install(args: argparse.Namespace) -> int:
    from stiction.setup.files import install_rules_command, install_text, is_root
    from stiction.setup.udev_rules import builtin_rules

    path: Path = args.path or _default_rules_path()
    text = builtin_rules()
    dry = args.dry_run or (args.path is None and not is_root())
    outcome = install_text(path, text, dry_run=dry, force=args.force, show="stiction udev print")
    if outcome.action == "unchanged":
        print(f"{path} is already up to date; nothing to do")
        return 0
    if outcome.action == "written":
        print(f"wrote {path}")
        print("reload udev and apply the rules to the devices already plugged in:")
        print(f"  {RELOAD_UDEV}")
        print("(or re-plug the tablet); then check with `stiction doctor`")
        return 0
    print(f"would write {path}:")
    print()
    sys.stdout.write(text)
    print()
    print(f"then reload udev: {RELOAD_UDEV}")
    if args.dry_run:
        return 0
    raise StictionError(
        f"not root, nothing written; run `{install_rules_command()}`, "
        f"or `stiction udev print | sudo tee {path}`"
    )


def _service_print(args: argparse.Namespace) -> int:
    from stiction.setup.service import render_unit, stictiond_executable

    sys.stdout.write(render_unit(stictiond_executable()))
    return 0


def _service_install(args: argparse.Namespace) -> int:
    from stiction.setup import service
    from stiction.setup.files import install_text

    unit = service.render_unit(service.stictiond_executable())
    config = service.config_path()
    verb = "would write" if args.dry_run else "wrote"
    done = install_text(
        service.unit_path(), unit, args.dry_run, force=args.force, show="stiction service print"
    )
    if done.action == "unchanged":
        print(f"{done.path} is already up to date")
    else:
        print(f"{verb} {done.path}")
    if config.exists():
        print(f"config: {config} (kept as it is)")
    else:
        install_text(config, service.STARTER_CONFIG, args.dry_run)
        print(f"{verb} a starter config {config}")
    if args.dry_run:
        print()
        sys.stdout.write(unit)
        print()
    print("start it now and at every log-in:")
    print("  systemctl --user daemon-reload && systemctl --user enable --now stictiond")
    print("follow its log:")
    print("  journalctl --user -u stictiond -f")
    return 0


def _doctor(args: argparse.Namespace) -> int:
    from stiction.setup import doctor, service
    from stiction.setup.udev_rules import builtin_rules

    if args.config is not None and not args.config.exists():
        raise StictionError(f"{args.config}: no such config file")
    # one that exists but is a directory or a FIFO is refused by the config reader, in words
    config: Path = args.config or service.config_path()
    findings = doctor.diagnose(config)
    rules = _rules_status(builtin_rules())
    # a problem on a node stictiond does not read (the hidraw twin of an evdev
    # tablet) is reported but does not make the device unusable
    usable = any(f.chosen for f in findings) and not any(f.blocks for f in findings)
    if args.json:
        print(
            json.dumps(
                {
                    "ok": usable,
                    "config": str(config),
                    "udev_rules": rules,
                    "devices": [f.as_json() for f in findings],
                }
            )
        )
        return 0 if usable else 1
    print(f"udev rules: {rules}")
    if not findings:
        print(
            "no tablets, touchpads or touchscreens found. Is one plugged in? "
            "(`stictiond` still runs on a synthetic pen without one)"
        )
        return 1
    for f in findings:
        head = f"{f.path}  {f.vid_pid}  {f.kind:<11} {f.backend:<6}  {f.name}"
        print(head)
        print(f"    {'chosen' if f.chosen else 'not chosen'}: {f.reason}")
        if f.ok:
            print(f"    ok: {f.detail}")
        else:
            print(f"    {'PROBLEM' if f.chosen else 'problem'} ({f.problem}): {f.detail}")
            print(f"    fix: {f.fix}")
    used = [f for f in findings if f.chosen]
    bad = sum(f.blocks for f in findings)
    print(
        f"{len(used) - bad} of {len(used)} devices usable"
        + ("" if not bad else "; fix the problems above and run `stiction doctor` again")
    )
    return 0 if usable else 1


def _rules_status(expected: str) -> str:
    """Where stiction's udev rules are installed, and whether they match this version."""
    from stiction.setup.files import install_rules_command
    from stiction.setup.udev_rules import RULES_NAME

    for directory in (RULES_DIR, Path("/run/udev/rules.d"), Path("/usr/lib/udev/rules.d")):
        path = directory / RULES_NAME
        try:
            text = path.read_text(encoding="utf-8")
        except OSError:
            continue
        if text == expected:
            return f"{path} (current)"
        return f"{path} differs from this version's rules: `{install_rules_command()}`"
    return f"not installed (`{install_rules_command()}` writes {_default_rules_path()})"


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add udev, service and doctor."""
    u = sub.add_parser(
        "udev",
        help="udev rules giving the logged-in user access to tablets (no root at run time)",
        description='Rules with TAG+="uaccess" for the hidraw nodes of the devices in the '
        "HID device table and for every tablet, touchpad and touchscreen event node.",
    )
    usub = u.add_subparsers(dest="udev_command", metavar="ACTION", required=True)
    p = usub.add_parser("print", help="print the rules")
    p.set_defaults(func=_udev_print)
    p = usub.add_parser(
        "install",
        help=f"write {_default_rules_path()} (as root) and say how to reload udev",
    )
    p.add_argument("--dry-run", action="store_true", help="only print what would be written")
    p.add_argument(
        "--force", action="store_true", help="replace an existing file whose content differs"
    )
    p.add_argument("--path", type=Path, help="write here instead (any user may, if writable)")
    p.set_defaults(func=_udev_install)

    s = sub.add_parser(
        "service",
        help="the systemd user unit running stictiond at log-in",
        description="A systemd --user unit for stictiond with its config in "
        "$XDG_CONFIG_HOME/stiction/stictiond.toml (default ~/.config/stiction/).",
    )
    ssub = s.add_subparsers(dest="service_command", metavar="ACTION", required=True)
    p = ssub.add_parser("print", help="print the unit as it would be installed")
    p.set_defaults(func=_service_print)
    p = ssub.add_parser(
        "install",
        help="write ~/.config/systemd/user/stictiond.service (and a starter config)",
    )
    p.add_argument("--dry-run", action="store_true", help="only print what would be written")
    p.add_argument(
        "--force", action="store_true", help="replace an existing file whose content differs"
    )
    p.set_defaults(func=_service_install)

    d = sub.add_parser(
        "doctor",
        help="check every tablet and touchpad: can stiction open it, and if not, why",
        description="Opens each candidate device as stictiond would (including a brief "
        "exclusive grab of evdev nodes) and explains every problem with its fix. "
        "Exit status 0 when every device found is usable.",
    )
    d.add_argument("--json", action="store_true", help="one JSON object")
    d.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="stictiond config whose device sizes and grabs apply "
        "(default $XDG_CONFIG_HOME/stiction/stictiond.toml, if it exists)",
    )
    d.set_defaults(func=_doctor)
