"""Rules planner latency per query over the paper's corpus, as a ratio to references in the same run.

References: `compile()` of the very program the planner produced (what any planner's output costs before
it can run), and, when the runner is installed, its static policy check `check_program`. Each figure is
the median over rounds of the mean time per query.

    .venv/bin/python benchmarks/bench_planning.py [--rounds 7] [--corpus PATH]

`--corpus tests/data/generalisation.jsonl` times the everyday phrasings of the generalisation protocol
(those the planner reads) instead of the paper's corpus. `--clock cpu` times with the process's CPU time
instead of the wall clock: on a machine shared with other work it is the steadier of the two, and what
compares two versions of the planner run one after the other (each with its own PYTHONPATH).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from attribot.errors import InputError
from attribot.planning.rules import rules_program

DEFAULT_CORPUS = None  # the corpus shipped in attribot.eval


def load_queries(path: Path | None) -> list[str]:
    from attribot.eval.corpus import paper_queries

    if path is None:
        rows = [q.model_dump(exclude_none=True) for q in paper_queries()]
    else:
        rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    queries = []
    for row in rows:
        if row.get("task") == "ai2thor_weight_scene_items":
            queries.append(f"Out of the {row['items']}, which one is the most lightweight?")
        elif "query" in row:
            queries.append(row["query"])
    return queries


CLOCKS = {"wall": time.perf_counter_ns, "cpu": time.process_time_ns}


def per_item_us(
    fn: Callable[[str], object],
    items: Sequence[str],
    rounds: int,
    clock: Callable[[], int] = time.perf_counter_ns,
) -> float:
    """Median over rounds of the mean microseconds per item."""
    samples = []
    for _ in range(rounds):
        start = clock()
        for item in items:
            fn(item)
        samples.append((clock() - start) / len(items) / 1000)
    return statistics.median(samples)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    args = parser.parse_args()
    clock = CLOCKS[args.clock]

    queries = load_queries(args.corpus)
    programs, readable = [], []
    for query in queries:
        try:
            programs.append(rules_program(query))
            readable.append(query)
        except InputError:  # refused, or (an action) not for a still image: not timed
            pass
    # warm both paths once (regex compilation, imports)
    for q in readable:
        rules_program(q)
    plan_us = per_item_us(rules_program, readable, args.rounds, clock)
    compile_us = per_item_us(lambda src: compile(src, "<program>", "exec"), programs, args.rounds, clock)
    print(
        f"corpus: {len(queries)} queries, {len(readable)} parsed, rounds: {args.rounds}, clock: {args.clock}"
    )
    print(f"rules planner: {plan_us:.1f} us/query")
    print(f"reference compile() of the produced program: {compile_us:.1f} us/program")
    print(f"ratio rules planner / compile(): {plan_us / compile_us:.2f}")
    try:
        from attribot.runner import check_program
    except ImportError:
        try:
            from attribot.runner.policy import check_program
        except ImportError:
            print("runner check_program: not installed, skipped")
            return
    check_us = per_item_us(check_program, programs, args.rounds, clock)
    print(f"reference runner check_program(): {check_us:.1f} us/program")
    print(f"ratio rules planner / check_program(): {plan_us / check_us:.2f}")


if __name__ == "__main__":
    main()
