"""Tests of scripts/glslang_diagnostics.py and its use by scripts/hlsl_check.py, without glslang:
a compile passes only on exit 0 with no error line, and a limit is named.

    python3 scripts/test_glslang_diagnostics.py
"""

import pathlib
import tempfile
import unittest

import hlsl_check
from glslang_diagnostics import SPIRV_ID_BOUND, report

# What glslangValidator 12.0 printed compiling the HLSL of `scripts/make-library 1000 1` built
# as one scene: its source's name on stdout, then the legaliser's errors on stderr, and exit 0.
OVERFLOW = "error: :0:0:0: ID overflow. Try running compact-ids."


def fake_validator(directory: pathlib.Path, stderr: str, status: int) -> str:
    """A stand-in for glslangValidator that prints `stderr` and exits `status`."""
    script = directory / "fake-glslang"
    script.write_text(f"#!/bin/sh\necho \"$(basename \"$7\")\"\nprintf '%s\\n' '{stderr}' >&2\nexit {status}\n")
    script.chmod(0o755)
    return str(script)


class Diagnostics(unittest.TestCase):
    def test_error_lines_fail_a_compile_that_exits_0_and_name_the_limit(self):
        failure = report(0, "library.hlsl\n" + f"{OVERFLOW}\n" * 567)
        self.assertIsNotNone(failure)
        self.assertIn("567 x " + OVERFLOW, failure)
        self.assertIn(f"{SPIRV_ID_BOUND:,}", failure)
        self.assertIn("exit 0 does not mean compiled", failure)

    def test_a_clean_compile_passes_warnings_and_paths_naming_errors_included(self):
        self.assertIsNone(report(0, "/tmp/error_maps/copper_pot.hlsl\n"))
        self.assertIsNone(report(0, "copper_pot.hlsl\nWARNING: 0:12: 'precise' : not supported\n"))

    def test_a_front_end_error_fails_with_its_message_and_no_limit(self):
        failure = report(2, "ERROR: 0:3: 'tmh_x' : undeclared identifier\nERROR: 1 compilation errors.\n")
        self.assertIn("1 x ERROR: 0:3: 'tmh_x' : undeclared identifier", failure)
        self.assertNotIn("limit:", failure)
        # A failing exit status with nothing recognised still fails, showing what was printed.
        self.assertIn("segfault", report(139, "segfault\n"))

    def test_the_hlsl_check_fails_a_file_whose_compiler_exits_0_with_errors(self):
        with tempfile.TemporaryDirectory() as work:
            work = pathlib.Path(work)
            shader = work / "forms" / "tir_fit.hlsl"
            shader.parent.mkdir()
            shader.write_text("float tmlut_tir(float mu, float alpha, float eta) {\n    return mu;\n}\n")
            scratch = work / "scratch"
            scratch.mkdir()
            failure = hlsl_check.compile_one(fake_validator(work, OVERFLOW, 0), shader, scratch)
            self.assertIsNotNone(failure)
            self.assertIn("ID overflow", failure)
            self.assertIsNone(hlsl_check.compile_one(fake_validator(work, "", 0), shader, scratch))


if __name__ == "__main__":
    unittest.main()
