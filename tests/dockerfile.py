"""What an image built from a Dockerfile would hold, assembled without a container engine.

A test reads the Dockerfile and copies files from the build context into a directory that
stands for the image's file system, following Docker's rules for COPY:

- the context is the build's root minus what ``.dockerignore`` excludes (a pattern excludes a
  path and everything below it; ``*`` and ``?`` stay within one path segment, ``**`` spans
  any number of them);
- a source is a path in the context; a source that is itself a link is followed, within the
  context;
- a directory source copies its contents, not the directory itself, merging into what the
  destination holds; a link inside it is copied as the link it is, so a relative link only
  resolves if what it points to is copied to the same relative place;
- a file source goes into a destination ending in ``/`` under its own name, else becomes the
  destination; several sources need a destination ending in ``/``;
- a relative destination is relative to the WORKDIR in force.

Only the instructions the project's Dockerfile uses are understood (FROM, WORKDIR, COPY, RUN,
USER, CMD, in their plain forms); anything else is refused rather than guessed at."""

from __future__ import annotations

import json
import re
import shlex
import shutil
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath


class DockerfileError(Exception):
    """The Dockerfile uses something this reader does not implement, or breaks a COPY rule."""


@dataclass
class Image:
    """The image's file system under ``root``, and what the instructions recorded."""

    root: Path
    base: str = ""
    workdir: PurePosixPath = field(default_factory=lambda: PurePosixPath("/"))
    runs: list[str] = field(default_factory=list)
    cmd: list[str] = field(default_factory=list)

    def path(self, inside: PurePosixPath | str) -> Path:
        """Where an absolute path of the image is in the assembled directory."""
        absolute = self.workdir / inside
        return self.root.joinpath(*absolute.parts[1:])


def instructions(text: str) -> list[tuple[str, str]]:
    """(instruction, arguments) in order: comments dropped, continued lines joined."""
    found: list[tuple[str, str]] = []
    pending = ""
    for line in text.splitlines():
        if not pending and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        whole = (pending + line).strip()
        pending = ""
        keyword, _, arguments = whole.partition(" ")
        found.append((keyword.upper(), arguments.strip()))
    if pending:
        raise DockerfileError("the Dockerfile ends inside a continued line")
    return found


def assemble(dockerfile: Path, context: Path, root: Path) -> Image:
    """The image ``dockerfile`` builds from ``context``, its files assembled under ``root``."""
    image = Image(root)
    ignored = Ignored.read(context / ".dockerignore")
    for keyword, arguments in instructions(dockerfile.read_text()):
        if keyword == "FROM":
            image.base = arguments
        elif keyword == "WORKDIR":
            image.workdir = image.workdir / arguments
            image.path(image.workdir).mkdir(parents=True, exist_ok=True)
        elif keyword == "COPY":
            copy(shlex.split(arguments), context, ignored, image)
        elif keyword == "RUN":
            image.runs.append(arguments)
        elif keyword == "USER":
            pass  # the account the image runs as: nothing of its files
        elif keyword == "CMD":
            image.cmd = exec_form(arguments)
        else:
            raise DockerfileError(f"instruction {keyword} is not understood by this reader")
    return image


def exec_form(arguments: str) -> list[str]:
    try:
        command = json.loads(arguments)
    except json.JSONDecodeError:
        command = None
    if not isinstance(command, list) or not all(isinstance(part, str) for part in command):
        raise DockerfileError(f"only the exec form (a JSON list) is understood: {arguments}")
    return command


def copy(arguments: list[str], context: Path, ignored: Ignored, image: Image) -> None:
    if len(arguments) < 2 or any(argument.startswith("--") for argument in arguments):
        raise DockerfileError(f"COPY {' '.join(arguments)}: only COPY SOURCE... DEST")
    *sources, destination = arguments
    into_directory = destination.endswith("/")
    if len(sources) > 1 and not into_directory:
        raise DockerfileError(f"COPY of several sources needs a DEST ending in /: {destination}")
    target = image.path(destination)
    for source in sources:
        found = context_path(source, context, ignored)
        if found.is_dir():
            copy_contents(found, target, context, ignored)
        else:
            file_target = target / found.name if into_directory else target
            file_target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(found, file_target)


def context_path(source: str, context: Path, ignored: Ignored) -> Path:
    """A COPY source in the context: followed if it is a link, never outside the context."""
    if any(character in source for character in "*?["):
        raise DockerfileError(f"COPY source {source}: wildcards are not understood")
    path = (context / source).resolve()
    if not path.is_relative_to(context.resolve()):
        raise DockerfileError(f"COPY source {source} is outside the build context")
    relative = path.relative_to(context.resolve()).as_posix()
    if not path.exists() or ignored.excludes(relative):
        raise DockerfileError(f"COPY source {source} is not in the build context")
    return path


def copy_contents(directory: Path, target: Path, context: Path, ignored: Ignored) -> None:
    """The contents of ``directory`` into ``target``, links kept as links."""
    base = context.resolve()

    def left_out(folder: str, names: list[str]) -> set[str]:
        relative = Path(folder).relative_to(base).as_posix()
        return {n for n in names if ignored.excludes(f"{relative}/{n}".removeprefix("./"))}

    shutil.copytree(directory, target, symlinks=True, ignore=left_out, dirs_exist_ok=True)


class Ignored:
    """The paths ``.dockerignore`` keeps out of the build context."""

    def __init__(self, patterns: list[str]) -> None:
        self._patterns = [segment_pattern(pattern) for pattern in patterns]

    @classmethod
    def read(cls, path: Path) -> Ignored:
        if not path.exists():
            return cls([])
        lines = [line.strip() for line in path.read_text().splitlines()]
        return cls([line for line in lines if line and not line.startswith("#")])

    def excludes(self, relative: str) -> bool:
        """Whether ``relative`` (a POSIX path from the context's root), or a folder above it,
        is excluded."""
        parts = relative.split("/")
        prefixes = ["/".join(parts[: end + 1]) + "/" for end in range(len(parts))]
        return any(p.fullmatch(prefix) for p in self._patterns for prefix in prefixes)


def segment_pattern(pattern: str) -> re.Pattern[str]:
    """A .dockerignore pattern as a regular expression over a path followed by ``/``."""
    if pattern.startswith("!") or "[" in pattern or "\\" in pattern:
        raise DockerfileError(f".dockerignore pattern {pattern}: not understood by this reader")
    regex = ""
    for segment in PurePosixPath(pattern.lstrip("/")).parts:
        if segment == "**":
            regex += "(?:[^/]+/)*"
            continue
        for character in segment:
            regex += {"*": "[^/]*", "?": "[^/]"}.get(character, re.escape(character))
        regex += "/"
    return re.compile(regex)
