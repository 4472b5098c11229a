"""Docs that do not drift: every section of BENCHMARKS.md or docs/long_runs.md that code,
config or docs cite by title exists (a citation may give a title's start, as long as that start
names one section)."""

from __future__ import annotations

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
REPORTS = {'BENCHMARKS.md': ROOT / 'BENCHMARKS.md',
           'docs/long_runs.md': ROOT / 'docs' / 'long_runs.md'}
# a citation: the report's name, optionally a comma and "section", then a quoted title; an
# apostrophe inside a word (004's) does not end a single-quoted title
CITATION = re.compile(r'(BENCHMARKS\.md|docs/long_runs\.md)`*,?\s+(?:section\s+)?'
                      r"(?:'((?:[^']|'(?=[a-z]))+)'|\"([^\"]+)\"|“([^”]+)”)")
SOURCES = sorted([*ROOT.glob('pam_bench/**/*.py'), *ROOT.glob('config/**/*.yaml'),
                  *ROOT.glob('docs/*.md'), ROOT / 'README.md', ROOT / 'Makefile',
                  *ROOT.glob('examples/**/*.py')])


def _headings(path: pathlib.Path) -> list[str]:
    return [m.group(1).strip() for m in re.finditer(r'^#{2,4} (.+)$',
                                                    path.read_text(encoding='utf-8'), re.M)]


def _flat(text: str) -> str:
    """Line breaks (and the comment marks of continued lines) as single spaces."""
    return re.sub(r'[ \t]*\n[ \t]*(?:#+[ \t]*)?', ' ', text)


def citations() -> list[tuple[str, str, str]]:
    """(file, report, title) of every citation in the sources."""
    out = []
    for path in SOURCES:
        for m in CITATION.finditer(_flat(path.read_text(encoding='utf-8'))):
            title = next(g for g in m.groups()[1:] if g)
            out.append((str(path.relative_to(ROOT)), m.group(1), ' '.join(title.split())))
    return out


CITED = citations()


def test_there_are_citations_to_check() -> None:
    assert len(CITED) > 50


@pytest.mark.parametrize('where, report, title', CITED,
                         ids=[f'{w}:{t[:30]}' for w, _, t in CITED])
def test_every_cited_section_exists(where: str, report: str, title: str) -> None:
    heads = _headings(REPORTS[report])
    matches = [h for h in heads if h == title] or [h for h in heads if h.startswith(title)]
    assert len(matches) == 1, f'{where} cites {report}, {title!r}: {len(matches)} sections match'
