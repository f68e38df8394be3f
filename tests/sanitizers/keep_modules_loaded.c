// LD_PRELOAD shim for the asan stage of scripts/ci-stages.sh: dlclose does nothing, so every shared object stays
// mapped until exit. Mesa unloads its driver (dlclose) when the last EGL display or OSMesa context goes; the memory its
// unloaded globals still pointed to then looks leaked to LeakSanitizer, from an "<unknown module>" that no suppression
// can name. With the driver kept mapped those blocks are reachable again and LeakSanitizer only reports real leaks
// (and names the module, so tests/sanitizers/lsan-mesa.supp can tell Mesa's own from Pleat's).
int dlclose( void* handle );

int dlclose( void* handle )
{
	(void)handle;
	return 0;
}
