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
- :mod:`~calibrator.inputs.errors`: :class:`StrictError` and :class:`ConsistencyError`.

The package sits below the arm's model and documents, which read their files
through it, and imports nothing above it. The checks that need the arm's
model (parts of documents that must agree, data and results plausible for
the arm) are :mod:`calibrator.model.consistency` and
:mod:`calibrator.model.plausibility`.
"""
