// Symbol visibility for libiris_engine: only what carries IRIS_API is exported.
#pragma once
#if defined(_WIN32)
#  if defined(IRIS_BUILDING_ENGINE)
#    define IRIS_API __declspec(dllexport)
#  else
#    define IRIS_API __declspec(dllimport)
#  endif
#else
#  define IRIS_API __attribute__((visibility("default")))
#endif
