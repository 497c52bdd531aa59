//! Physics validation and end-to-end tests of dea-mpi: the tests are in `tests/`; this library is empty.
