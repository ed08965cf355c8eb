/* bcryptprimitives.dll for Wine 8 (Debian 12), which has none: Rust's standard library (1.78+)
 * takes its random seeds from ProcessPrng there, as on Windows 10 and later, which Blender 4.2+
 * requires anyway. This stand-in fills the buffer from advapi32's RtlGenRandom. A test-harness
 * file only: it is never packaged, and real Windows has the DLL. */
#include <windows.h>
#include <ntsecapi.h>

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len) {
    while (len > 0) {
        ULONG n = len > 0x7fffffff ? 0x7fffffff : (ULONG)len;
        if (!RtlGenRandom(data, n)) return FALSE;
        data += n;
        len -= n;
    }
    return TRUE;
}
