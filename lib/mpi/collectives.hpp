// digilap internal — the few MPI collectives the distributed pipeline needs, typed, and the rule
// that keeps an error from hanging the other ranks: a stage that may throw runs through
// on_every_rank, which makes every rank throw the first failing rank's message.
#pragma once

#include "digilap/core/error.hpp"

#include <mpi.h>
#include <petscsys.h>

#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <vector>

namespace digilap::mpi::detail {

struct Ranks {
  MPI_Comm comm;
  int rank = 0, size = 1;
  explicit Ranks(MPI_Comm c) : comm(c) {
    MPI_Comm_rank(c, &rank);
    MPI_Comm_size(c, &size);
  }
};

template <class T> MPI_Datatype mpi_type();
template <> inline MPI_Datatype mpi_type<std::int64_t>() { return MPI_INT64_T; }
template <> inline MPI_Datatype mpi_type<int>() { return MPI_INT; }
template <> inline MPI_Datatype mpi_type<double>() { return MPI_DOUBLE; }

template <class T>
void all_reduce(const Ranks& r, std::vector<T>& values, MPI_Op op) {
  MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), mpi_type<T>(), op, r.comm);
}
template <class T>
T all_reduce(const Ranks& r, T value, MPI_Op op) {
  MPI_Allreduce(MPI_IN_PLACE, &value, 1, mpi_type<T>(), op, r.comm);
  return value;
}
/// Every rank's values, concatenated in rank order, on every rank.
template <class T>
std::vector<T> all_gather(const Ranks& r, const std::vector<T>& mine) {
  std::vector<int> counts(static_cast<std::size_t>(r.size)), displs(static_cast<std::size_t>(r.size), 0);
  int count = static_cast<int>(mine.size());
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, r.comm);
  for (int q = 1; q < r.size; ++q) displs[q] = displs[q - 1] + counts[q - 1];
  std::vector<T> all(static_cast<std::size_t>(displs.back() + counts.back()));
  MPI_Allgatherv(mine.data(), count, mpi_type<T>(), all.data(), counts.data(), displs.data(), mpi_type<T>(), r.comm);
  return all;
}
/// send[q] to rank q; returns what every rank sent here, concatenated in rank order.
template <class T>
std::vector<T> all_to_all(const Ranks& r, const std::vector<std::vector<T>>& send) {
  std::vector<int> send_counts(static_cast<std::size_t>(r.size)), recv_counts(static_cast<std::size_t>(r.size));
  std::vector<int> send_displs(static_cast<std::size_t>(r.size), 0), recv_displs(static_cast<std::size_t>(r.size), 0);
  std::vector<T> flat;
  for (int q = 0; q < r.size; ++q) {
    send_counts[q] = static_cast<int>(send[q].size());
    send_displs[q] = static_cast<int>(flat.size());
    flat.insert(flat.end(), send[q].begin(), send[q].end());
  }
  MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, r.comm);
  for (int q = 1; q < r.size; ++q) recv_displs[q] = recv_displs[q - 1] + recv_counts[q - 1];
  std::vector<T> received(static_cast<std::size_t>(recv_displs.back() + recv_counts.back()));
  MPI_Alltoallv(flat.data(), send_counts.data(), send_displs.data(), mpi_type<T>(), received.data(), recv_counts.data(),
                recv_displs.data(), mpi_type<T>(), r.comm);
  return received;
}

/// Runs f (which returns a value) on every rank. When it throws on some rank, every rank throws
/// digilap::Error with the message of the lowest such rank: the others would otherwise wait
/// forever in the next collective.
template <class F>
auto on_every_rank(const Ranks& r, F&& f) -> decltype(f()) {
  std::optional<decltype(f())> result;
  std::string message;
  try {
    result.emplace(f());
  } catch (const std::exception& e) {
    message = e.what();
  }
  const int first = all_reduce(r, result ? r.size : r.rank, MPI_MIN);
  if (first < r.size) {
    int length = static_cast<int>(message.size());
    MPI_Bcast(&length, 1, MPI_INT, first, r.comm);
    message.resize(static_cast<std::size_t>(length));
    MPI_Bcast(message.data(), length, MPI_CHAR, first, r.comm);
    throw Error(message);
  }
  return std::move(*result);
}

/// PETSc's error code as a digilap::Error.
inline void petsc_check(PetscErrorCode code, const char* what) {
  if (code != 0) throw Error(std::string("PETSc/SLEPc: ") + what + " failed (error code " + std::to_string(code) + ")");
}

}  // namespace digilap::mpi::detail
