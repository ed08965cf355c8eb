/* The entry point of python3.dll, the stable-ABI DLL built here as forwarders to python3XX.dll
 * (the Maven Central CPython has no python3.dll, which abi3 extensions import from). */
int __stdcall DllMainCRTStartup(void *module, unsigned reason, void *reserved) { return 1; }
