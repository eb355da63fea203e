#include "tests/support/no_heap_guard.h"

#include <cstdlib>
#include <new>

namespace {

thread_local bool t_active = false;
thread_local std::size_t t_allocs = 0;
thread_local std::size_t t_frees = 0;
thread_local bool t_abort = false;  // HYQ_NO_HEAP_ABORT=1: abort at the allocation (for gdb)

inline void NoteAlloc() noexcept {
  if (!t_active) return;
  ++t_allocs;
  if (t_abort) std::abort();
}
inline void NoteFree() noexcept {
  if (t_active) ++t_frees;
}

}  // namespace

namespace hyq::testing {

NoHeapGuard::NoHeapGuard() noexcept
    : alloc_start_(t_allocs), free_start_(t_frees), outer_active_(t_active) {
  const char* env = std::getenv("HYQ_NO_HEAP_ABORT");
  t_abort = env != nullptr && env[0] == '1';
  t_active = true;
}
NoHeapGuard::~NoHeapGuard() { t_active = outer_active_; }
std::size_t NoHeapGuard::allocations() const noexcept { return t_allocs - alloc_start_; }
std::size_t NoHeapGuard::deallocations() const noexcept { return t_frees - free_start_; }

bool NoHeapGuard::Available() noexcept {
#if defined(HYQ_SANITIZED)
  return false;
#else
  return true;
#endif
}

}  // namespace hyq::testing

#if !defined(HYQ_SANITIZED)

// glibc exports its allocator under these names, so the replacements below can forward to it.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t n) {
  NoteAlloc();
  return __libc_malloc(n);
}
void* calloc(std::size_t count, std::size_t n) {
  NoteAlloc();
  return __libc_calloc(count, n);
}
void* realloc(void* p, std::size_t n) {
  NoteAlloc();
  return __libc_realloc(p, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
  NoteAlloc();
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) {
  NoteAlloc();
  void* p = __libc_memalign(alignment, n);
  if (p == nullptr) return 12;  // ENOMEM
  *out = p;
  return 0;
}
void free(void* p) {
  if (p != nullptr) NoteFree();
  __libc_free(p);
}
}  // extern "C"

namespace {
void* NewOrThrow(std::size_t n) {
  NoteAlloc();
  void* p = __libc_malloc(n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* NewAlignedOrThrow(std::size_t n, std::align_val_t a) {
  NoteAlloc();
  void* p = __libc_memalign(static_cast<std::size_t>(a), n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void Delete(void* p) noexcept {
  if (p != nullptr) NoteFree();
  __libc_free(p);
}
}  // namespace

void* operator new(std::size_t n) { return NewOrThrow(n); }
void* operator new[](std::size_t n) { return NewOrThrow(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  NoteAlloc();
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  NoteAlloc();
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new(std::size_t n, std::align_val_t a) { return NewAlignedOrThrow(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return NewAlignedOrThrow(n, a); }
void operator delete(void* p) noexcept { Delete(p); }
void operator delete[](void* p) noexcept { Delete(p); }
void operator delete(void* p, std::size_t) noexcept { Delete(p); }
void operator delete[](void* p, std::size_t) noexcept { Delete(p); }
void operator delete(void* p, std::align_val_t) noexcept { Delete(p); }
void operator delete[](void* p, std::align_val_t) noexcept { Delete(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { Delete(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { Delete(p); }

#endif  // !HYQ_SANITIZED
