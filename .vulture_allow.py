"""Names that `python -m vulture src .vulture_allow.py --min-confidence 60` (.ci/run) would report as
unused, and why each stays.  Vulture counts a name used when it appears here; keep one line of reason a
name, and add a name only when nothing in src/ can read it by design (an API field, a command-line
choice).  Dead code is deleted, not listed."""

# public API (minparam, docs/api.md): fields and methods of the result records, read by the caller
_.joint_types  # Robot.joint_types, CheckResult.joint_types (api/results.py)
_.description  # Robot.description: the loaded description record
_.test_rigid  # Identification.test_rigid: the rigid model's errors on the test data
_.sigma_ratio  # Singularity.sigma_ratio
_.condition_number_si  # Excitation.condition_number_si: the condition number in SI units
_.to_csv  # Excitation.to_csv (docs/commands/excite.md)
_.relative_per_joint  # Errors.relative_per_joint (minparam.Errors): ‖r_j‖/‖τ_j‖ per joint
_.kept_names  # BaseSet.kept_names (docs/api.md): the names of the kept columns
_.dependent_names  # BaseSet.dependent_names (docs/api.md)
_.unidentifiable_names  # BaseSet.unidentifiable_names (docs/api.md)
_.nominal_parameters  # Robot.nominal_parameters (docs/mjcf.md): the file's inertials and MJCF armature/friction

# PEP 562: `minparam_cli.cli.app.app` is built on first access
__getattr__  # cli/app.py; minparam/__init__.py (the API loads on first use)
__dir__  # minparam/__init__.py: dir(minparam) lists the names loaded on first use

# members of the commands' str Enums: typer picks them by value from the command line
_.python  # codegen --lang python
_.projection  # derive/codegen --method projection
_.logdet  # excite --criterion logdet
_.jsonl  # derive --format jsonl
_.bootstrap  # identify --sigma bootstrap
_.textbook  # identify --sigma textbook
_.ms  # identify --time-unit ms
_.us  # identify --time-unit us
_.pso  # platform fk --method pso
_.multistart  # platform fk --method multistart

# the noise-free positions of simulated data: tests/test_simulate*.py check the position noise against them
_.q_true  # experiment/simulate.py Simulation.q_true, Chunk.q_true
