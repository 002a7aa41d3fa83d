"""The checks of what users hand in, in one place: one module per job.

Every reader of a user's file or option checks it through here, so a quirk
of one parser cannot turn into silently wrong data and every refusal is one
line (exit code 2 at the CLI):

- :mod:`~calibrator.inputs.grammar`: the one number grammar (decimal only);
- :mod:`~calibrator.inputs.jsonfile`: strict JSON (no duplicate keys, NaN, overflow);
- :mod:`~calibrator.inputs.yamlfile`: the one YAML reader (size, depth, aliases, keys);
- :mod:`~calibrator.inputs.textfile`: a text file within its size, as UTF-8;
- :mod:`~calibrator.inputs.budgets`: sizes and times refused above their limit;
- :mod:`~calibrator.inputs.rules`: what one option may be, for the command line and files;
- :mod:`~calibrator.inputs.messages`: values cut short for one-line messages;
- :mod:`~calibrator.inputs.json_fields`: numbers and tables of a parsed document;
- :mod:`~calibrator.inputs.session_table`: the columns and rows of a session file;
- :mod:`~calibrator.inputs.consistency`: parts of documents that must agree;
- :mod:`~calibrator.inputs.plausibility`: data and results plausible for the arm;
- :mod:`~calibrator.inputs.errors`: :class:`StrictError` and :class:`ConsistencyError`.

The package sits below the arm's model and documents, which read their files
through it: a document reader hands these checks what they compare with (a
catalogue table, a session's column names). Its one import from above is
:mod:`calibrator.model.kinematics` (the MDH table's columns, and the forward
kinematics the scale check of :mod:`~calibrator.inputs.plausibility` needs),
listed in ``tests/static/test_layers.py`` until it has a home.
"""
