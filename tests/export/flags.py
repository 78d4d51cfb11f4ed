"""The flags the export tests build the package with: its Makefile's, warnings as errors."""

WARNINGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off")
