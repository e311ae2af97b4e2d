"""Tasks, one package each (`tasks.push`, …), and the contract every task follows
(`tasks.contract`). Importing this package imports no task."""
