"""The start values of a Jacobi run as libcosim takes them: libcosim iterates its
initialisation once per component (every output read, then passed on to the inputs it feeds),
so a value at the start of a chain of feedthrough blocks reaches its end before the first
step. Here: after every component is initialised, the Jacobi point's input writes and
feedthrough evaluations at the start time, once less than there are components (the outputs
read after initialisation are libcosim's first read)."""
from __future__ import annotations

from twmr.master.plan import Evaluate, Write, build
from twmr.scenario.system import System


def propagate_start_values(system: System) -> int:
    """Pass the outputs at the start time on to the inputs (and evaluate the feedthrough
    blocks) `components - 1` times; the number of rounds."""
    comps = system.components
    plan = build(system, "jacobi", [], 1, check_finite=False)
    writes = [a for a in plan.point if isinstance(a, Write)]
    if not writes or len(comps) < 2:
        return 0
    ports = {name: comp.__dict__ for name, comp in comps.items()}

    def ref(name: str, port: str) -> str:
        return f"_p[{name!r}][{port!r}]"

    lines = [f"s{k} = {ref(*key)}" for k, key in enumerate(plan.snapshot)]
    lines += [plan.assignment(w, ref) for w in writes]
    code = compile("\n".join(lines), f"<twmr jacobi start {system.source}>", "exec")
    evaluated = [comps[a.name] for a in plan.point if isinstance(a, Evaluate)]
    t = system.experiment.start
    rounds = len(comps) - 1
    for _ in range(rounds):
        exec(code, {"_p": ports})  # noqa: S102 - generated here from the plan's own writes
        for comp in evaluated:
            comp.evaluate(t)
    return rounds
