#pragma once
// The server's closed sets of states and kinds, each an enum with exactly one table of names:
// the names are what JSON, the database's TEXT columns (and their CHECK constraints in
// migrations/) and the logs carry. A new enum adds itself here the same way: the enum, then an
// EnumNames specialisation listing every value.
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {

enum class Role { kVehicle, kReader, kAdmin };
enum class SessionState { kOpen, kCommitting, kCommitted, kFailed };
enum class JobType { kCommit, kRefresh, kReclassify, kRollback };
enum class JobState { kQueued, kRunning, kSucceeded, kFailed, kCancelled };
enum class PriorSource { kImport, kRefresh, kRollback };  // how a prior version was made
// A change cluster's kind and lifecycle state (change_cluster_store.hpp): candidate ->
// confirmed -> applied -> expired, or rejected; expired is final, rejected ends the automatic
// lifecycle (an admin may still confirm it).
enum class ClusterKind { kNew, kRemoved };
enum class ClusterState { kCandidate, kConfirmed, kApplied, kExpired, kRejected };

// EnumNames<E>::kValues lists every value of E (declaration order) with its name;
// EnumNames<E>::kWhat names the set in error messages.
template <typename E>
struct EnumNames;

template <typename E, size_t N>
using NameTable = std::array<std::pair<E, std::string_view>, N>;

template <>
struct EnumNames<Role> {
  static constexpr std::string_view kWhat = "role";
  static constexpr NameTable<Role, 3> kValues{
      {{Role::kVehicle, "vehicle"}, {Role::kReader, "reader"}, {Role::kAdmin, "admin"}}};
};

template <>
struct EnumNames<SessionState> {
  static constexpr std::string_view kWhat = "session state";
  static constexpr NameTable<SessionState, 4> kValues{{{SessionState::kOpen, "open"},
                                                       {SessionState::kCommitting, "committing"},
                                                       {SessionState::kCommitted, "committed"},
                                                       {SessionState::kFailed, "failed"}}};
};

template <>
struct EnumNames<JobType> {
  static constexpr std::string_view kWhat = "job type";
  static constexpr NameTable<JobType, 4> kValues{{{JobType::kCommit, "commit"},
                                                  {JobType::kRefresh, "refresh"},
                                                  {JobType::kReclassify, "reclassify"},
                                                  {JobType::kRollback, "rollback"}}};
};

template <>
struct EnumNames<JobState> {
  static constexpr std::string_view kWhat = "job state";
  static constexpr NameTable<JobState, 5> kValues{{{JobState::kQueued, "queued"},
                                                   {JobState::kRunning, "running"},
                                                   {JobState::kSucceeded, "succeeded"},
                                                   {JobState::kFailed, "failed"},
                                                   {JobState::kCancelled, "cancelled"}}};
};

template <>
struct EnumNames<PriorSource> {
  static constexpr std::string_view kWhat = "prior source";
  static constexpr NameTable<PriorSource, 3> kValues{{{PriorSource::kImport, "import"},
                                                      {PriorSource::kRefresh, "refresh"},
                                                      {PriorSource::kRollback, "rollback"}}};
};

template <>
struct EnumNames<ClusterKind> {
  static constexpr std::string_view kWhat = "cluster kind";
  static constexpr NameTable<ClusterKind, 2> kValues{
      {{ClusterKind::kNew, "new"}, {ClusterKind::kRemoved, "removed"}}};
};

template <>
struct EnumNames<ClusterState> {
  static constexpr std::string_view kWhat = "cluster state";
  static constexpr NameTable<ClusterState, 5> kValues{{{ClusterState::kCandidate, "candidate"},
                                                       {ClusterState::kConfirmed, "confirmed"},
                                                       {ClusterState::kApplied, "applied"},
                                                       {ClusterState::kExpired, "expired"},
                                                       {ClusterState::kRejected, "rejected"}}};
};

template <typename E>
concept NamedEnum = requires {
  EnumNames<E>::kValues;
};

template <NamedEnum E>
constexpr std::string_view ToString(E value) {
  for (const auto& [v, name] : EnumNames<E>::kValues) {
    if (v == value) return name;
  }
  return "?";  // unreachable for a value of E: every enumerator is in its table
}

template <NamedEnum E>
constexpr std::optional<E> ParseEnum(std::string_view text) {
  for (const auto& [v, name] : EnumNames<E>::kValues) {
    if (name == text) return v;
  }
  return std::nullopt;
}

// For text read back from storage: an unknown name means a corrupt or foreign database.
template <NamedEnum E>
E ParseEnumOrThrow(std::string_view text, std::string_view where) {
  if (auto v = ParseEnum<E>(text)) return *v;
  throw Error(ErrorCode::kParse, std::string(where) + ": unknown " +
                                     std::string(EnumNames<E>::kWhat) + " '" + std::string(text) +
                                     "'");
}

}  // namespace mapdelta::server
