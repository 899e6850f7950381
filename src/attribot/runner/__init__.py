"""The sandboxed program runner: a separate, killable process that reaches the API only over a pipe.

`ProgramRunner(classes=[...], limits=Limits(...)).run(source, args=[...]) -> RunResult`;
`check_program(source) -> RunError | None` is the static policy check alone.
"""

from attribot.runner.host import ProgramRunner
from attribot.runner.policy import check_program
from attribot.runner.records import Limits, RunError, RunResult, TraceRecord

__all__ = ["ProgramRunner", "Limits", "RunError", "RunResult", "TraceRecord", "check_program"]
