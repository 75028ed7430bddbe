/* Test-only shim for the asan preset: makes dlclose() a no-op.
 *
 * The Vulkan loader unloads the driver (lavapipe) and layer libraries when an instance is
 * destroyed. Allocations those libraries keep for the process's life then show up in
 * LeakSanitizer's report with "<unknown module>" frames, which no suppression can name.
 * Keeping them mapped lets the report name them, so tests/lsan.supp can suppress exactly
 * those libraries while every leak in project code is still reported. */
int dlclose(void* handle) {
    (void)handle;
    return 0;
}
