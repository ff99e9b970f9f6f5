#pragma once
/// @file
/// ByteBudgetCache: a thread-safe least-recently-used cache bounded by bytes (images, rasters,
/// feature sets), where each key is loaded once however many threads ask for it at once.

#include <cstddef>
#include <exception>
#include <functional>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <type_traits>
#include <unordered_map>
#include <utility>

#include <diachron/core/error.hpp>

namespace diachron {

/// Options of ByteBudgetCache.
struct ByteBudgetCacheOptions {
  /// Bytes the cache may keep, the sum of the size function over its entries (> 0). Default 1 GiB.
  std::size_t budget_bytes = std::size_t{1} << 30;

  /// Throws diachron::Error naming the first invalid field.
  void check() const { DIACHRON_CHECK(budget_bytes > 0, "ByteBudgetCacheOptions::budget_bytes must be > 0"); }
};

/// Counters of a ByteBudgetCache since it was made (clear() keeps them).
struct ByteBudgetCacheStats {
  std::size_t hits = 0;          ///< get() calls answered without calling their loader
  std::size_t joined = 0;        ///< of the hits, those that waited for another thread's load of the key
  std::size_t misses = 0;        ///< loader calls (loads), failed ones included
  std::size_t failed_loads = 0;  ///< of the misses, loads that threw (nothing stored)
  std::size_t not_kept = 0;      ///< loaded values larger than the whole budget: returned, not kept
  std::size_t evictions = 0;     ///< entries dropped to make room (erase() and clear() not counted)
  std::size_t entries = 0;       ///< entries kept now
  std::size_t resident_bytes = 0;       ///< bytes kept now (<= budget_bytes)
  std::size_t peak_resident_bytes = 0;  ///< the most bytes kept at once (<= budget_bytes)
};

/// A least-recently-used cache of `std::shared_ptr<const Value>` under a byte budget.
///
/// `get(key, loader)` returns the value of `key`: a stored one (a hit, which makes it the most
/// recently used), or the loader's. A miss calls the loader once even when several threads ask for
/// the same key at the same time: the others wait for that load and get the same pointer, and if
/// the loader throws, each of them gets the exception and nothing is stored (the next get() loads
/// again). After a load the value is stored as the most recently used entry and the least recently
/// used entries are evicted until the kept bytes fit the budget; a value larger than the whole
/// budget is returned but not kept (and evicts nothing).
///
/// The budget bounds what the cache keeps, not what the program holds: a value handed out stays
/// alive as long as a caller holds its shared_ptr, evicted or not. Bytes are what the size
/// function says (e.g. `width * height * channels` of an image); it is called once per load, on
/// the loading thread.
///
/// @tparam Key hashable with `Hash` and compared with `KeyEqual` (an `std::unordered_map` key);
///   copied into the cache.
/// @tparam Value any type; held as `const`.
///
/// \note Thread safety: every member may be called from any thread at once. No lock is held while
/// a loader runs, so loads of different keys run in parallel, and a loader may call get() for
/// other keys; a loader that asks for its own key waits for itself forever. The cache must outlive
/// every get() call in progress.
template <typename Key, typename Value, typename Hash = std::hash<Key>, typename KeyEqual = std::equal_to<Key>>
class ByteBudgetCache {
 public:
  using ValuePtr = std::shared_ptr<const Value>;
  /// Bytes of a value (any callable `std::size_t(const Value&)`).
  using SizeFunction = std::function<std::size_t(const Value&)>;

  /// Precondition: `options.check()` passes and `size_bytes` is not empty (else diachron::Error).
  ByteBudgetCache(const ByteBudgetCacheOptions& options, SizeFunction size_bytes)
      : options_(options), size_bytes_(std::move(size_bytes)) {
    options_.check();
    DIACHRON_CHECK(static_cast<bool>(size_bytes_), "ByteBudgetCache needs a size function");
  }
  ByteBudgetCache(const ByteBudgetCache&) = delete;
  ByteBudgetCache& operator=(const ByteBudgetCache&) = delete;

  /// The value of `key`, loaded by `loader()` on a miss. The loader returns a `Value` (moved into a
  /// new shared_ptr) or anything convertible to `std::shared_ptr<const Value>` (`shared_ptr<Value>`,
  /// `unique_ptr<Value>`); a null pointer is an error (diachron::Error, to every waiter). What the
  /// loader (or the size function) throws reaches every get() waiting for that load.
  template <typename Loader>
  ValuePtr get(const Key& key, Loader&& loader);

  /// The stored value of `key`, or null; neither counted nor made the most recently used.
  ValuePtr peek(const Key& key) const;

  /// Drops the stored value of `key` (a load in progress is not affected); true if there was one.
  bool erase(const Key& key);

  /// Drops every stored value (loads in progress are not affected, and store their values).
  void clear();

  ByteBudgetCacheStats stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
  }
  const ByteBudgetCacheOptions& options() const { return options_; }

 private:
  struct Entry {
    ValuePtr value;
    std::size_t bytes = 0;
    typename std::list<Key>::iterator recency;  // into recency_, front = most recently used
  };

  template <typename Loader>
  static ValuePtr call_loader(Loader& loader);
  void store_locked(const Key& key, ValuePtr value, std::size_t bytes);

  ByteBudgetCacheOptions options_;
  SizeFunction size_bytes_;
  mutable std::mutex mutex_;
  std::list<Key> recency_;
  std::unordered_map<Key, Entry, Hash, KeyEqual> entries_;
  std::unordered_map<Key, std::shared_future<ValuePtr>, Hash, KeyEqual> loading_;
  ByteBudgetCacheStats stats_;
};

// Implementation ---------------------------------------------------------------------------------

template <typename Key, typename Value, typename Hash, typename KeyEqual>
template <typename Loader>
typename ByteBudgetCache<Key, Value, Hash, KeyEqual>::ValuePtr
ByteBudgetCache<Key, Value, Hash, KeyEqual>::call_loader(Loader& loader) {
  using Result = std::decay_t<decltype(loader())>;
  if constexpr (std::is_convertible_v<Result, ValuePtr>) {
    ValuePtr value = loader();
    DIACHRON_CHECK(value != nullptr, "the loader of a ByteBudgetCache returned a null pointer");
    return value;
  } else {
    static_assert(std::is_constructible_v<Value, Result>,
                  "A ByteBudgetCache loader must return a Value or a pointer convertible to "
                  "std::shared_ptr<const Value>.");
    return std::make_shared<const Value>(loader());
  }
}

template <typename Key, typename Value, typename Hash, typename KeyEqual>
template <typename Loader>
typename ByteBudgetCache<Key, Value, Hash, KeyEqual>::ValuePtr
ByteBudgetCache<Key, Value, Hash, KeyEqual>::get(const Key& key, Loader&& loader) {
  std::promise<ValuePtr> promise;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto found = entries_.find(key);
    if (found != entries_.end()) {
      recency_.splice(recency_.begin(), recency_, found->second.recency);
      ++stats_.hits;
      return found->second.value;
    }
    const auto in_flight = loading_.find(key);
    if (in_flight != loading_.end()) {
      std::shared_future<ValuePtr> future = in_flight->second;
      ++stats_.hits;
      ++stats_.joined;
      lock.unlock();
      return future.get();  // the loader's value, or its exception
    }
    loading_.emplace(key, promise.get_future().share());
    ++stats_.misses;
  }
  // This thread loads, without the lock.
  ValuePtr value;
  std::size_t bytes = 0;
  try {
    value = call_loader(loader);
    bytes = size_bytes_(*value);
  } catch (...) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      loading_.erase(key);
      ++stats_.failed_loads;
    }
    promise.set_exception(std::current_exception());
    throw;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    loading_.erase(key);
    store_locked(key, value, bytes);
  }
  promise.set_value(value);
  return value;
}

template <typename Key, typename Value, typename Hash, typename KeyEqual>
void ByteBudgetCache<Key, Value, Hash, KeyEqual>::store_locked(const Key& key, ValuePtr value,
                                                                std::size_t bytes) {
  if (bytes > options_.budget_bytes) {
    ++stats_.not_kept;
    return;
  }
  // A value stored meanwhile (erase() or clear() then a get() that loaded again): replace it.
  const auto old = entries_.find(key);
  if (old != entries_.end()) {
    stats_.resident_bytes -= old->second.bytes;
    recency_.erase(old->second.recency);
    entries_.erase(old);
  }
  recency_.push_front(key);
  entries_.emplace(key, Entry{std::move(value), bytes, recency_.begin()});
  stats_.resident_bytes += bytes;
  // Least recently used first; the new entry (at the front, within the budget) stays.
  while (stats_.resident_bytes > options_.budget_bytes) {
    const auto victim = entries_.find(recency_.back());
    stats_.resident_bytes -= victim->second.bytes;
    entries_.erase(victim);
    recency_.pop_back();
    ++stats_.evictions;
  }
  stats_.entries = entries_.size();
  if (stats_.resident_bytes > stats_.peak_resident_bytes) stats_.peak_resident_bytes = stats_.resident_bytes;
}

template <typename Key, typename Value, typename Hash, typename KeyEqual>
typename ByteBudgetCache<Key, Value, Hash, KeyEqual>::ValuePtr
ByteBudgetCache<Key, Value, Hash, KeyEqual>::peek(const Key& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = entries_.find(key);
  return found == entries_.end() ? nullptr : found->second.value;
}

template <typename Key, typename Value, typename Hash, typename KeyEqual>
bool ByteBudgetCache<Key, Value, Hash, KeyEqual>::erase(const Key& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = entries_.find(key);
  if (found == entries_.end()) return false;
  stats_.resident_bytes -= found->second.bytes;
  recency_.erase(found->second.recency);
  entries_.erase(found);
  stats_.entries = entries_.size();
  return true;
}

template <typename Key, typename Value, typename Hash, typename KeyEqual>
void ByteBudgetCache<Key, Value, Hash, KeyEqual>::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.clear();
  recency_.clear();
  stats_.resident_bytes = 0;
  stats_.entries = 0;
}

}  // namespace diachron
