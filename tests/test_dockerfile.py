"""The Dockerfile reader follows Docker's COPY rules, refuses what it does not implement, and
the project's image holds the package with every link resolved. Installing
and running what it holds: tests/e2e/test_image.py."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.dockerfile import DockerfileError, Ignored, assemble

ROOT = Path(__file__).resolve().parent.parent


def build(tmp_path: Path, dockerfile: str, files: dict[str, str]) -> Path:
    """A context holding ``files`` (a value starting with ``->`` makes a link), assembled."""
    context = tmp_path / "context"
    for name, content in files.items():
        path = context / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if content.startswith("->"):
            path.symlink_to(content[2:].strip())
        else:
            path.write_text(content)
    (context / "Dockerfile").write_text(dockerfile)
    return assemble(context / "Dockerfile", context, tmp_path / "image").root


def test_a_directory_copies_its_contents_and_keeps_links_as_links(tmp_path: Path) -> None:
    root = build(
        tmp_path,
        "WORKDIR /app\nCOPY pkg ./pkg\nCOPY lib ./lib\n",
        {"pkg/__init__.py": "", "pkg/lib": "-> ../lib", "lib/code.py": "x = 1"},
    )
    assert os.readlink(root / "app/pkg/lib") == "../lib"
    assert (root / "app/pkg/lib/code.py").read_text() == "x = 1"
    assert not (root / "app/pkg/pkg").exists()


def test_a_link_to_a_folder_not_copied_dangles(tmp_path: Path) -> None:
    root = build(
        tmp_path,
        "WORKDIR /app\nCOPY pkg ./pkg\n",
        {"pkg/__init__.py": "", "pkg/lib": "-> ../lib", "lib/code.py": ""},
    )
    assert (root / "app/pkg/lib").is_symlink()
    assert not (root / "app/pkg/lib").exists()


def test_a_source_that_is_a_link_is_followed(tmp_path: Path) -> None:
    root = build(
        tmp_path,
        "COPY alias /data/\n",
        {"real/a.txt": "a", "alias": "-> real"},
    )
    assert (root / "data/a.txt").read_text() == "a"
    assert not (root / "data").is_symlink()


def test_a_file_goes_under_its_name_or_becomes_the_destination(tmp_path: Path) -> None:
    root = build(
        tmp_path,
        "WORKDIR /w\nCOPY a.txt b.txt ./\nCOPY a.txt /etc/renamed\n",
        {"a.txt": "a", "b.txt": "b"},
    )
    assert (root / "w/a.txt").read_text() == "a"
    assert (root / "w/b.txt").read_text() == "b"
    assert (root / "etc/renamed").read_text() == "a"


def test_dockerignore_keeps_paths_and_everything_below_out(tmp_path: Path) -> None:
    root = build(
        tmp_path,
        "COPY src /s\n",
        {
            ".dockerignore": "**/__pycache__\nsrc/secret\n*.log\n",
            "src/m.py": "",
            "src/__pycache__/m.pyc": "",
            "src/deep/__pycache__/n.pyc": "",
            "src/secret/key": "",
            "src/kept.log": "",
        },
    )
    assert sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()) == [
        "s/kept.log",
        "s/m.py",
    ]


@pytest.mark.parametrize(
    ("dockerfile", "reason"),
    [
        ("ENV A=1\n", "instruction ENV is not understood"),
        ("COPY a b c\n", "needs a DEST ending in /"),
        ("COPY --chown=x a /a\n", "only COPY SOURCE... DEST"),
        ("COPY *.txt /a/\n", "wildcards are not understood"),
        ("COPY ../outside /a\n", "outside the build context"),
        ("COPY missing /a\n", "is not in the build context"),
        ("CMD python -m x\n", "only the exec form"),
    ],
)
def test_what_the_reader_does_not_implement_is_refused(
    tmp_path: Path, dockerfile: str, reason: str
) -> None:
    (tmp_path / "outside").write_text("")
    with pytest.raises(DockerfileError, match=reason):
        build(tmp_path, dockerfile, {"a": "", "b": ""})


def test_dockerignore_exceptions_are_refused() -> None:
    with pytest.raises(DockerfileError, match="not understood"):
        Ignored(["!keep"])


def test_the_image_holds_the_package_with_every_link_resolved(tmp_path: Path) -> None:
    image = assemble(ROOT / "deploy" / "Dockerfile", ROOT, tmp_path / "image")
    source = image.path(image.workdir)
    links = [path for path in (source / "motocell").iterdir() if path.is_symlink()]
    assert {link.name for link in links} == {
        link.name for link in (ROOT / "motocell").iterdir() if link.is_symlink()
    }
    dangling = [
        link.name for link in links if not (link.is_dir() and link.resolve().is_relative_to(source))
    ]
    assert not dangling, (
        f"deploy/Dockerfile copies motocell/ but not the folders its links {dangling} point to: "
        "add a COPY line for each"
    )
    assert (source / "motocell/services/gateway/__main__.py").is_file()
    for needed in ("pyproject.toml", "README.md", "LICENSE", "MANIFEST.in"):
        assert (source / needed).is_file(), needed
    copied = [path.relative_to(image.root).as_posix() for path in image.root.rglob("*")]
    assert not [name for name in copied if "__pycache__" in name]


def test_the_context_leaves_out_the_venv_caches_and_credentials() -> None:
    ignored = Ignored.read(ROOT / ".dockerignore")
    for path in (".venv/bin/python", "shared/__pycache__/x.pyc", "deploy/credentials/ca.pem"):
        assert ignored.excludes(path), path
    assert not ignored.excludes("shared/bus/credentials.py")
