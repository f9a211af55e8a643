"""The command lines, ``ftc-mj run|figures|report|campaign|tune``: the top of the package, thin clients of the
library below (nothing in the library imports them).

Each command is one module with ``build_parser(prog)`` and ``main(argv, prog) -> exit status``; :mod:`.main`
dispatches ``ftc-mj COMMAND ...`` to them. Commands import the heavy modules (MuJoCo, Rerun, matplotlib, Arrow)
only once their arguments are read, so ``--help`` answers at once. The older forms ``python -m ftc_mj.run``,
``python -m ftc_mj.figures``, ``python -m ftc_mj.report``, ``python -m ftc_mj.tune`` and
``python -m ftc_mj.campaign`` run the same code.

Exit status, for every command: 0 on success, 2 on bad input (one line ``FILE: FIELD: PROBLEM``, nothing
written), others as each command says.
"""
