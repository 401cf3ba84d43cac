"""Progress for a person (app/evaluation/progress.py): on a terminal (a real pseudo-terminal
here) one line rewritten in place with a bar; in a file or pipe a line per tenth of the runs."""

from __future__ import annotations

import io
import os
import tty

from app.evaluation.progress import ProgressLine, bar, progress_printer


def read_all(master: int) -> str:
    """Everything written to a closed pseudo-terminal's slave: read until EIO, then close."""
    chunks = []
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(master)
    return b"".join(chunks).decode("utf-8")


def test_not_a_terminal_gets_a_line_per_tenth_not_one_per_run():
    stream = io.StringIO()
    report = progress_printer("bench robust: 189 runs ...", stream, label="bench robust")
    for done in range(1, 190):
        report(done, 189)
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue()
    assert lines[0] == "bench robust: 189 runs ..."
    assert 10 <= len(lines[1:]) <= 11  # the first run, each tenth, the end
    assert lines[1].startswith("bench robust: 1/189 runs, ")
    assert lines[-1].startswith("bench robust: 189/189 runs, ") and lines[-1].endswith("0 s left")
    counts = [int(line.split(": ")[1].split("/")[0]) for line in lines[1:]]
    assert counts == sorted(set(counts))  # each tenth once, in order
    assert {19, 38, 57, 76, 95, 114, 133, 152, 171} <= set(counts)  # 10 %, 20 %, ... reached


def test_each_generation_of_a_study_counts_anew():
    stream = io.StringIO()
    line = ProgressLine(stream)
    for generation in (1, 2):
        for done in range(1, 41):
            line.update(done, 40, f"generation {generation}: {done}/40 runs")
    lines = stream.getvalue().splitlines()
    assert [x for x in lines if x.endswith(" 40/40 runs")] == [
        "generation 1: 40/40 runs",
        "generation 2: 40/40 runs",
    ]
    assert len(lines) == 2 * 11 and lines[11] == "generation 2: 1/40 runs"


def test_a_terminal_gets_one_line_rewritten_in_place_with_a_bar():
    master, slave = os.openpty()
    tty.setraw(slave)  # the bytes as written, without the terminal's \n -> \r\n
    with open(slave, "w", encoding="utf-8", closefd=True) as stream:
        assert stream.isatty()
        report = progress_printer("tune: 20 runs ...", stream, label="tune")
        for done in range(1, 21):
            report(done, 20)
    text = read_all(master)
    note, rest = text.split("\n", 1)
    assert note == "tune: 20 runs ..."
    assert rest.endswith("\n") and rest.count("\n") == 1  # one line, ended when all are done
    updates = rest.rstrip("\n").split("\r")[1:]
    assert len(updates) == 20
    assert updates[9].startswith(f"tune: {bar(10, 20)} 10/20 runs, ")
    assert updates[-1].startswith(f"tune: {bar(20, 20)} 20/20 runs, ")


def test_a_shorter_update_wipes_the_longer_one_before_it():
    master, slave = os.openpty()
    tty.setraw(slave)
    with open(slave, "w", encoding="utf-8", closefd=True) as stream:
        line = ProgressLine(stream)
        line.update(1, 3, "a long first text")
        line.update(2, 3, "short")
    text = read_all(master)  # one read may return only the first write's bytes
    assert text == "\ra long first text\rshort" + " " * 12
