"""The package's numba machinery: one jit policy (``jit``), kernels compiled on their own
(``separate``), one compile at a time across processes (``kernel_lock``), what each scene's
first run compiles (``compile_plan``) and the helper processes that compile it ahead
(``compile_helpers``, ``warmup``), and what compiled while a run went on (``compile_log``,
``stage_ledger``). Nothing here is physics or geometry."""
