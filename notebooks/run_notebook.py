"""Run a Jupyter notebook's code cells in order, headless, without Jupyter.

The notebooks here are plain Python in notebook form; executing their cells in one namespace is
what a kernel would do. Exits non-zero, naming the cell, if any cell raises.

Run: python3 notebooks/run_notebook.py notebooks/reports.ipynb
"""
import json
import sys
import traceback

path = sys.argv[1]
notebook = json.load(open(path))
namespace = {"__name__": "__main__"}
for number, cell in enumerate(notebook["cells"], start=1):
    if cell["cell_type"] != "code":
        continue
    source = "".join(cell["source"])
    try:
        exec(compile(source, f"{path} cell {number}", "exec"), namespace)
    except Exception:
        traceback.print_exc()
        sys.exit(f"{path}: cell {number} failed")
print(f"{path}: every cell ran")
