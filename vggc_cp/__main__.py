from vggc_cp.cli import run

run()
