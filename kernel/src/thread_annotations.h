// Clang's thread-safety annotations (-Wthread-safety), as macros that are
// no-ops under other compilers. They let the compiler check, at build time,
// that members marked GUARDED_BY(mu) are touched only with `mu` held and that
// functions marked REQUIRES(mu) are called only with it held. See
// https://clang.llvm.org/docs/ThreadSafetyAnalysis.html; `./run tsan` builds
// with clang and the analysis on.
#pragma once

#if defined(__clang__)
#define PEIS_THREAD_ANNOTATION(x) __attribute__((x))
#else
#define PEIS_THREAD_ANNOTATION(x)
#endif

#define CAPABILITY(x) PEIS_THREAD_ANNOTATION(capability(x))
#define SCOPED_CAPABILITY PEIS_THREAD_ANNOTATION(scoped_lockable)
#define GUARDED_BY(x) PEIS_THREAD_ANNOTATION(guarded_by(x))
#define PT_GUARDED_BY(x) PEIS_THREAD_ANNOTATION(pt_guarded_by(x))
#define REQUIRES(...) PEIS_THREAD_ANNOTATION(requires_capability(__VA_ARGS__))
#define EXCLUDES(...) PEIS_THREAD_ANNOTATION(locks_excluded(__VA_ARGS__))
#define ACQUIRE(...) PEIS_THREAD_ANNOTATION(acquire_capability(__VA_ARGS__))
#define RELEASE(...) PEIS_THREAD_ANNOTATION(release_capability(__VA_ARGS__))
#define TRY_ACQUIRE(...) PEIS_THREAD_ANNOTATION(try_acquire_capability(__VA_ARGS__))
#define ASSERT_CAPABILITY(x) PEIS_THREAD_ANNOTATION(assert_capability(x))
#define NO_THREAD_SAFETY_ANALYSIS PEIS_THREAD_ANNOTATION(no_thread_safety_analysis)
