"""Run glslangValidator and judge the compile by what it prints, not only by its exit status.

    python3 scripts/glslang_diagnostics.py GLSLANG_VALIDATOR ARGUMENT...

glslangValidator exits 0 after some failures: on the HLSL of a 1,000-material library its
SPIR-V legaliser (SPIRV-Tools, which it runs on HLSL) printed `error: :0:0:0: ID overflow. Try
running compact-ids.` 567 times and the module it wrote was not the shader. So a compile passes
only where the validator exits 0 *and* prints no error line; a failure is reported with each
distinct error once, its count, and, where the error is a limit of the compiler or of SPIR-V, the
limit by name and value. As a command, exits 1 on such a failure, printing the report.
"""

import re
import subprocess
import sys

# SPIR-V's universal limit on the id bound (the SPIR-V specification, "Universal Limits": result
# <id> bound 4,194,303), which SPIRV-Tools' passes hold ids to.
SPIRV_ID_BOUND = 4_194_303

# A diagnostic of the compiler or of SPIRV-Tools: `ERROR: 0:12: ...`, `error: :0:0:0: ...`.
ERROR_LINE = re.compile(r"^\s*error\b\s*:", re.IGNORECASE)

# Errors that are a limit of the compiler or of SPIR-V rather than of the source: what to name.
LIMITS = [
    (
        re.compile(r"ID overflow", re.IGNORECASE),
        f"the module needs more SPIR-V ids than the id bound allows ({SPIRV_ID_BOUND:,}, SPIR-V's universal "
        "limit, which SPIRV-Tools' legalisation passes hold to): too much code in one entry point; compile "
        "fewer functions into one module",
    ),
]


def errors(output: str) -> list[str]:
    """The error lines of the validator's output (stdout and stderr together)."""
    return [line.strip() for line in output.splitlines() if ERROR_LINE.match(line)]


def report(returncode: int, output: str) -> str | None:
    """None where the compile passed (exit 0, no error line); else what failed, each distinct
    error once with its count, and the limit it names where it is one."""
    found = errors(output)
    if returncode == 0 and not found:
        return None
    counts: dict[str, int] = {}
    for line in found:
        counts[line] = counts.get(line, 0) + 1
    lines = [
        f"glslang exited {returncode} and printed {len(found)} error line(s)"
        + (" (exit 0 does not mean compiled)" if returncode == 0 else "")
    ]
    for line, count in counts.items():
        lines.append(f"  {count} x {line}")
    for pattern, limit in LIMITS:
        if any(pattern.search(line) for line in counts):
            lines.append(f"  limit: {limit}")
    if not found:
        lines.append(output.strip())
    return "\n".join(lines)


def compile_checked(validator: str, arguments: list[str]) -> str | None:
    """Run `validator arguments...`; None where it compiled, else the [`report`]."""
    result = subprocess.run([validator, *arguments], capture_output=True, text=True)
    return report(result.returncode, result.stdout + result.stderr)


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    failure = compile_checked(sys.argv[1], sys.argv[2:])
    if failure is not None:
        print(f"FAIL {' '.join(sys.argv[2:])}:\n{failure}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
