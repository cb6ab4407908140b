"""The README's "Live page and event store" section: its screenshot exists, its commands use
options that the commands have (the tour itself runs in tests/cli/test_readme_tour.py)."""

import re
import shlex
from pathlib import Path

import click

from leakdiag.cli.main import cli

ROOT = Path(__file__).resolve().parents[2]


def _section() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("### Live page and event store")
    return text[start:text.index("\n### ", start + 1)]


def test_readme_shows_the_live_page_with_a_screenshot():
    sec = _section()
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", sec)
    assert images == ["docs/images/dashboard-live.png"]
    png = (ROOT / images[0]).read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    from PIL import Image

    with Image.open(ROOT / images[0]) as im:
        w, h = im.size
    assert w >= 800 and h >= 500


def test_readme_dashboard_commands_use_existing_options():
    block = re.search(r"```bash\n(.*?)```", _section(), re.S).group(1).replace("\\\n", " ")
    cmds = [shlex.split(ln) for ln in block.splitlines() if ln.strip() and
            not ln.strip().startswith("#")]
    assert [c[:2] for c in cmds] == [["leakdiag", "detect"], ["leakdiag", "monitor"],
                                     ["leakdiag", "dashboard"]]
    ctx = click.Context(cli)
    for args in cmds:
        cmd = cli.get_command(ctx, args[1])
        opts = {o for p in cmd.params for o in p.opts}
        used = {a for a in args[2:] if a.startswith("--")}
        assert used <= opts, (args[1], used - opts)
        assert "--store" in used
