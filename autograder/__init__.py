"""The course autograder: grade student packages against the reference runs (DESIGN section 7).

``grading.grade`` grades a folder of submissions, ``api.check`` and ``api.selfcheck`` run the public
checks for a student. The layout, the checks and the security model are described in README.md.

This file imports nothing: the sandbox child loads this package before any student code.
"""
