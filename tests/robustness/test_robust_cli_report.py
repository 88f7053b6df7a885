"""render --report: only the Figures section is replaced (what follows it is kept), and a report that is a symbolic
link, or has its own permissions, is written through the link with its mode kept."""

import errno
import os
import stat

import pytest

from tissuesim.commands.render import link_figures
from tissuesim.io import replaced_atomically

REPORT = """# Results

Intro.

## Figures

![old](old.png)

### Figure notes

Old notes belong to the old figures.

## Discussion

The user's own discussion.
"""


def test_the_sections_after_figures_are_kept(tmp_path):
    report = tmp_path / "report.md"
    report.write_text(REPORT)
    link_figures(report, [tmp_path / "deformation_cube.png"])
    text = report.read_text()
    assert text.startswith("# Results\n\nIntro.\n\n## Figures\n")
    assert text.endswith("\n## Discussion\n\nThe user's own discussion.\n")
    assert "![deformation_cube](deformation_cube.png)" in text
    assert "old.png" not in text and "Figure notes" not in text    # a subsection belongs to the section replaced
    link_figures(report, [tmp_path / "deformation_cube.png"])      # a second run changes nothing
    assert report.read_text() == text


def test_a_report_without_figures_gets_them_at_its_end(tmp_path):
    report = tmp_path / "report.md"
    report.write_text("# Results\n\n## Discussion\n\nText.\n")
    link_figures(report, [tmp_path / "a.png"])
    assert report.read_text().startswith("# Results\n\n## Discussion\n\nText.\n\n## Figures\n\n")


def test_a_symlinked_report_is_written_through_its_link_keeping_its_mode(tmp_path):
    real = tmp_path / "notes" / "real.md"
    real.parent.mkdir()
    real.write_text("# Mine\n")
    os.chmod(real, 0o600)
    link = tmp_path / "report.md"
    link.symlink_to(real)
    link_figures(link, [tmp_path / "a.png"])
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert "## Figures" in real.read_text()
    assert stat.S_IMODE(real.stat().st_mode) == 0o600


@pytest.mark.parametrize("named", [True, False])
def test_a_failed_whole_file_write_names_the_file_meant_not_its_temporary(named, tmp_path):
    target = tmp_path / "deformation_cube.png"
    with pytest.raises(OSError) as caught:
        with replaced_atomically(target) as partial:
            partial.write_bytes(b"\x89PNG")
            raise OSError(errno.ENOSPC, "No space left on device", *([str(partial)] if named else []))
    assert caught.value.filename == str(target) and ".partial" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []
