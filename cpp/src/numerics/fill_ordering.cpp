#include "numerics/fill_ordering.hpp"

#include "numerics/cholmod_view.hpp"

#include <cholmod.h>

#include <algorithm>
#include <list>
#include <mutex>
#include <new>
#include <stdexcept>
#include <utility>

namespace deformkit {

Ordering amd_ordering(const SymmetricLower& a) {
  Ordering perm(std::size_t(a.n));
  if (a.n == 0) return perm;
  cholmod_common common;
  cholmod_l_start(&common);
  common.print = 0;
  cholmod_sparse m = cholmod_view(a, false);
  const int ok = cholmod_l_amd(&m, nullptr, 0, reinterpret_cast<SuiteSparse_long*>(perm.data()), &common);
  const int status = common.status;
  cholmod_l_finish(&common);
  if (status == CHOLMOD_OUT_OF_MEMORY) throw std::bad_alloc();
  if (!ok) throw std::runtime_error("CHOLMOD's AMD could not order the matrix");
  return perm;
}

namespace {

std::mutex g_orderings_mutex;
std::list<std::pair<std::uint64_t, std::shared_ptr<const Ordering>>> g_orderings;  // most recent first
constexpr std::size_t kKeptOrderings = 8;

}  // namespace

std::shared_ptr<const Ordering> remembered_ordering(std::uint64_t key, const std::function<Ordering()>& compute,
                                                    bool* hit) {
  {
    const std::lock_guard<std::mutex> lock(g_orderings_mutex);
    for (auto it = g_orderings.begin(); it != g_orderings.end(); ++it)
      if (it->first == key) {
        g_orderings.splice(g_orderings.begin(), g_orderings, it);
        if (hit) *hit = true;
        return g_orderings.front().second;
      }
  }
  auto made = std::make_shared<const Ordering>(compute());  // outside the lock: it takes a while
  const std::lock_guard<std::mutex> lock(g_orderings_mutex);
  g_orderings.emplace_front(key, made);
  if (g_orderings.size() > kKeptOrderings) g_orderings.pop_back();
  if (hit) *hit = false;
  return made;
}

void forget_remembered_orderings() {
  const std::lock_guard<std::mutex> lock(g_orderings_mutex);
  g_orderings.clear();
}

Ordering restricted_ordering(const Ordering& ordering, const std::vector<int>& new_index, int width) {
  Ordering out;
  out.reserve(ordering.size() * std::size_t(width));
  for (std::int64_t i : ordering) {
    const int to = new_index[std::size_t(i)];
    if (to >= 0)
      for (int a = 0; a < width; ++a) out.push_back(std::int64_t(to) * width + a);
  }
  return out;
}

}  // namespace deformkit
