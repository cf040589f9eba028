// SA_INTEGRATOR_GAUSS_LEGENDRE: the same Green's theorem walk as the default (green.glsl), every
// edge integral ∫ D(s) V(s) ds by plain Gauss-Legendre with SA_GL_NODES nodes (2, 4, 8, 16 or 32)
// over the whole interval, the sharp lobe included. What a renderer without the closed form
// would do; the speed-against-accuracy study (`scratchart study`) charts it against the closed
// form. Error: the lobe's poles y = s - s0 = ±i g sit at distance g from the real axis, so on an
// interval of half-length L the rule converges like rho^(-2N) with rho ≈ 1 + g / L: fine for
// wide lobes (g ≳ L), useless for a sharp lobe on a long interval (alpha = 1e-3, L = 1: rho^-64
// ≈ 0.94). The nodes and weights were computed by Newton's method on the Legendre polynomials
// (float64, tabulated to 16 digits).
#ifndef SA_INTEGRATOR_GAUSS_LEGENDRE_GLSL
#define SA_INTEGRATOR_GAUSS_LEGENDRE_GLSL

#ifndef SA_GL_NODES
#define SA_GL_NODES 8
#endif
#if 0
#elif SA_GL_NODES == 2
const int GL_HALF = 1;
const float GL_X[1] = float[](0.5773502691896257);
const float GL_W[1] = float[](1.0000000000000002);
#elif SA_GL_NODES == 4
const int GL_HALF = 2;
const float GL_X[2] = float[](0.3399810435848563, 0.8611363115940526);
const float GL_W[2] = float[](0.6521451548625461, 0.3478548451374537);
#elif SA_GL_NODES == 8
const int GL_HALF = 4;
const float GL_X[4] = float[](0.1834346424956498, 0.5255324099163290, 0.7966664774136268, 0.9602898564975363);
const float GL_W[4] = float[](0.3626837833783620, 0.3137066458778874, 0.2223810344533745, 0.1012285362903762);
#elif SA_GL_NODES == 16
const int GL_HALF = 8;
const float GL_X[8] = float[](0.0950125098376374, 0.2816035507792589, 0.4580167776572274, 0.6178762444026438, 0.7554044083550030, 0.8656312023878318, 0.9445750230732326, 0.9894009349916499);
const float GL_W[8] = float[](0.1894506104550685, 0.1826034150449236, 0.1691565193950026, 0.1495959888165768, 0.1246289712555339, 0.0951585116824929, 0.0622535239386478, 0.0271524594117541);
#elif SA_GL_NODES == 32
const int GL_HALF = 16;
const float GL_X[16] = float[](0.0483076656877383, 0.1444719615827965, 0.2392873622521371, 0.3318686022821277, 0.4213512761306353, 0.5068999089322294, 0.5877157572407623, 0.6630442669302152, 0.7321821187402897, 0.7944837959679424, 0.8493676137325700, 0.8963211557660521, 0.9349060759377397, 0.9647622555875064, 0.9856115115452684, 0.9972638618494816);
const float GL_W[16] = float[](0.0965400885147279, 0.0956387200792748, 0.0938443990808045, 0.0911738786957639, 0.0876520930044037, 0.0833119242269467, 0.0781938957870704, 0.0723457941088486, 0.0658222227763619, 0.0586840934785356, 0.0509980592623762, 0.0428358980222267, 0.0342738629130214, 0.0253920653092621, 0.0162743947309057, 0.0070186100094701);
#else
#error SA_GL_NODES must be 2, 4, 8, 16 or 32
#endif

R edge_integral(PairGeom G, R lo, R hi, R Vlo, R Vhi) {
    R mid = mul(0.5, add(lo, hi)), hw = mul(0.5, sub(hi, lo));
    R Vm = mul(0.5, add(Vlo, Vhi)), dV = mul(0.5, sub(Vhi, Vlo));
    R sum = rc(0.0);
    for (int i = 0; i < GL_HALF; ++i) {
        R a = ndf_at(G, sub(mid, mul(GL_X[i], hw))), b = ndf_at(G, add(mid, mul(GL_X[i], hw)));
        sum = add(sum, mul(GL_W[i], add(mul(a, sub(Vm, mul(GL_X[i], dV))), mul(b, add(Vm, mul(GL_X[i], dV))))));
    }
    return mul(sum, hw);
}

#include "green.glsl"

#endif
