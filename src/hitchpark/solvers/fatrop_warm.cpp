// fatrop's C interface (fatrop/ocp/OCPCInterface.h, the one CasADi's generated fatrop solver calls), with a
// warm start of the multipliers.
//
// fatrop 1.1.8, the one CasADi 3.8 bundles, starts every solve from the primal guess it is given, bound
// multipliers of 1 and least-squares equality multipliers: it takes no multipliers. An NMPC step's problem is
// its predecessor's shifted by one step, and so are its multipliers; started from them, fatrop needs a third
// to a half fewer iterations on the full and obstacle OCPs (``hitchpark bench``).
//
// This file defines the functions of that interface itself and is linked into a generated solver's library,
// whose calls it then answers (-Wl,-Bsymbolic): the same algorithm, built by fatrop's own IpAlgBuilder, with
// one part replaced, the initializer. It runs fatrop's initializer and then, when the caller asked for it
// (hitchpark_fatrop_set_warm), sets the equality multipliers to the caller's and each bound multiplier to
// the caller's multiplier of that bound, at least ``floor`` (fatrop's initializer then skips its own
// least-squares equality multipliers, a solve of the KKT system the caller's replace). The caller's multipliers come from the
// generated C (hitchpark_warm_duals, in the layout fatrop reports its own in), from its lam_x0 and lam_g0.
// Without that request a solve is fatrop's to the last bit.
//
// fatrop offers no hook for a component of its own: the builder keeps the parts it builds private, and so
// does the algorithm its initializer. Hence the one `#define private public` below, around fatrop's headers
// only (the standard headers they use are included before it). Should a CasADi ship headers this does not
// compile against, the library is built without this file (hitchpark.solvers.generated).

#include <blasfeo.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <iomanip>
#include <iosfwd>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <variant>
#include <vector>

#define private public
#include "fatrop/fatrop.hpp"
#include "fatrop/ip_algorithm/ip_eq_mult_initializer.hpp"
#include "fatrop/ip_algorithm/ip_initializer.hpp"
#include "fatrop/ocp/type.hpp"
#define FATROP_OCP_SOLVER_IMPLEMENTATION
#include "fatrop/ocp/OCPCInterfaceInternal.hpp"
#undef private

using fatrop::Index;
using fatrop::OcpType;

// Defined in the generated C (hitchpark.solvers.generated): the caller's multipliers in fatrop's layout.
// Weak: a library whose C could not take it has no warm start, and no unresolved symbol.
extern "C" int hitchpark_warm_duals(void *user_data, double *dual_eq) __attribute__((weak));

namespace
{
    // Set by the caller before each solve, in the thread that then calls the solver.
    thread_local bool warm_requested = false;
    thread_local double warm_floor = 1e-9;
    thread_local int last_iterations = 0;

    // An equality multiplier initializer that leaves them as they are.
    class NoEqMult : public fatrop::IpEqMultInitializerBase
    {
    public:
        void initialize_eq_mult(bool) override {}
        void register_options(fatrop::OptionRegistry &) override {}
        void reset() override {}
    };

    // fatrop's initializer, then the caller's multipliers where asked for.
    class WarmInitializer : public fatrop::IpInitializerBase
    {
    public:
        WarmInitializer(std::shared_ptr<fatrop::IpInitializerBase> stock,
                        std::shared_ptr<fatrop::IpData<OcpType>> data, void *user_data)
            : stock_(std::move(stock)), data_(std::move(data)), user_data_(user_data)
        {
        }

        void initialize() override
        {
            if (!warm_requested || hitchpark_warm_duals == nullptr)
                return stock_->initialize();
            auto &it = data_->current_iterate();
            const Index n_eq = it.dual_eq().m();
            duals_.assign(static_cast<size_t>(n_eq), 0.);
            bool usable = hitchpark_warm_duals(user_data_, duals_.data()) == 0;
            for (double d : duals_)
                usable = usable && std::isfinite(d);
            if (!usable)
                return stock_->initialize();  // fatrop's own start
            // fatrop's initializer without its last part, the least-squares equality multipliers (a solve
            // of the whole KKT system), which the caller's replace.
            auto stock = std::dynamic_pointer_cast<fatrop::IpInitializer<OcpType>>(stock_);
            if (stock)
            {
                auto least_squares = stock->eq_mult_initializer_;
                stock->eq_mult_initializer_ = skip_;
                try
                {
                    stock_->initialize();
                }
                catch (...)
                {
                    stock->eq_mult_initializer_ = least_squares;
                    throw;
                }
                stock->eq_mult_initializer_ = least_squares;
            }
            else
                stock_->initialize();
            fatrop::VecRealAllocated eq(n_eq);
            for (Index i = 0; i < n_eq; ++i)
                eq(i) = duals_[static_cast<size_t>(i)];
            // A bound L <= g_ineq <= U is g_ineq - s = 0 with L <= s <= U: the multiplier of that equality
            // is the bound's, negative at the lower bound and positive at the upper one (CasADi's sign).
            const Index n_s = it.primal_s().m();
            const Index offset = it.info().offset_g_eq_slack;
            fatrop::VecRealAllocated lower(n_s), upper(n_s);
            for (Index i = 0; i < n_s; ++i)
            {
                const double lam = duals_[static_cast<size_t>(offset + i)];
                lower(i) = it.lower_bounded()[i] ? std::max(-lam, warm_floor) : 0.;
                upper(i) = it.upper_bounded()[i] ? std::max(lam, warm_floor) : 0.;
            }
            it.set_dual_eq(eq);
            it.set_dual_bounds_l(lower);
            it.set_dual_bounds_u(upper);
        }

        void register_options(fatrop::OptionRegistry &) override {}
        void reset() override { stock_->reset(); }

    private:
        std::shared_ptr<fatrop::IpInitializerBase> stock_;
        std::shared_ptr<fatrop::IpData<OcpType>> data_;
        void *user_data_;
        std::vector<double> duals_;
        std::shared_ptr<fatrop::IpEqMultInitializerBase> skip_ = std::make_shared<NoEqMult>();
    };
} // namespace

namespace fatrop
{
    struct FatropOcpCSolver
    {
        std::shared_ptr<FatropOcpCMapping> nlp;
        OptionRegistry registry;
        std::shared_ptr<IpAlgorithm<OcpType>> algorithm;
        std::shared_ptr<IpData<OcpType>> data;
        FatropOcpCStats stats{};
        // The arrays FatropOcpCDims points into.
        std::vector<fatrop_int> ux, g, dyn, dyn_eq, g_ineq, ineq, nu, nx, ng, ng_ineq;
    };

    template <typename T> static int set_registry_option(FatropOcpCSolver *s, const char *name, const T &value)
    {
        try
        {
            s->registry.set_option(name, value);
        }
        catch (const std::exception &)
        {
            return 1;
        }
        return 0;
    }

    extern "C"
    {
        FatropOcpCSolver *fatrop_ocp_c_create(FatropOcpCInterface *ocp, FatropOcpCWrite, FatropOcpCFlush)
        {
            auto *s = new FatropOcpCSolver();
            s->nlp = std::make_shared<FatropOcpCMapping>(ocp);
            IpAlgBuilder<OcpType> builder(s->nlp);
            builder.with_options_registry(&s->registry);
            s->algorithm = builder.build();
            s->data = builder.get_ipdata();
            s->algorithm->initializer_ =
                std::make_shared<WarmInitializer>(builder.initializer_, s->data, ocp->user_data);
            // The dimensions and offsets the caller reads the solution with (and the mapping evaluates with).
            const auto &info = s->data->info();
            const auto &dims = info.dims;
            auto copy = [](std::vector<fatrop_int> &to, const std::vector<Index> &from)
            { to.assign(from.begin(), from.end()); };
            copy(s->ux, info.offsets_primal_u);
            copy(s->g, info.offsets_g_eq_path);
            copy(s->dyn, info.offsets_dyn);
            copy(s->dyn_eq, info.offsets_g_eq_dyn);
            copy(s->g_ineq, info.offsets_g_eq_slack);
            copy(s->ineq, info.offsets_slack);
            copy(s->nu, dims.number_of_controls);
            copy(s->nx, dims.number_of_states);
            copy(s->ng, dims.number_of_eq_constraints);
            copy(s->ng_ineq, dims.number_of_ineq_constraints);
            auto most = [](const std::vector<fatrop_int> &v)
            { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); };
            FatropOcpCDims &d = s->nlp->s;
            d.ux_offs = s->ux.data();
            d.g_offs = s->g.data();
            d.dyn_offs = s->dyn.data();
            d.dyn_eq_offs = s->dyn_eq.data();
            d.g_ineq_offs = s->g_ineq.data();
            d.ineq_offs = s->ineq.data();
            d.nu = s->nu.data();
            d.nx = s->nx.data();
            d.ng = s->ng.data();
            d.ng_ineq = s->ng_ineq.data();
            d.max_nu = most(s->nu);
            d.max_nx = most(s->nx);
            d.max_ng = most(s->ng);
            d.max_ngineq = most(s->ng_ineq);
            d.n_ineqs = info.number_of_slack_variables;
            d.K = dims.K;
            return s;
        }

        fatrop_int fatrop_ocp_c_solve(FatropOcpCSolver *s)
        {
            IpSolverReturnFlag flag;
            try
            {
                flag = s->algorithm->optimize();
            }
            catch (const std::exception &)
            {
                s->stats.return_flag = -1;
                return -1;
            }
            s->stats.iterations_count = s->data->iteration_number();
            s->stats.return_flag = static_cast<int>(flag);
            last_iterations = s->stats.iterations_count;
            return flag == IpSolverReturnFlag::Success ? 0 : static_cast<int>(flag);
        }

        int fatrop_ocp_c_set_option_double(FatropOcpCSolver *s, const char *name, double value)
        {
            return set_registry_option(s, name, value);
        }
        int fatrop_ocp_c_set_option_bool(FatropOcpCSolver *s, const char *name, int value)
        {
            return set_registry_option(s, name, value != 0);
        }
        int fatrop_ocp_c_set_option_int(FatropOcpCSolver *s, const char *name, int value)
        {
            return set_registry_option(s, name, static_cast<Index>(value));
        }
        int fatrop_ocp_c_set_option_string(FatropOcpCSolver *s, const char *name, const char *value)
        {
            return set_registry_option(s, name, std::string(value));
        }
        const blasfeo_dvec *fatrop_ocp_c_get_primal(FatropOcpCSolver *s)
        {
            return &s->algorithm->solution_primal().vec();
        }
        const blasfeo_dvec *fatrop_ocp_c_get_dual(FatropOcpCSolver *s)
        {
            return &s->algorithm->solution_dual().vec();
        }
        const FatropOcpCDims *fatrop_ocp_c_get_dims(FatropOcpCSolver *s) { return &s->nlp->s; }
        const FatropOcpCStats *fatrop_ocp_c_get_stats(FatropOcpCSolver *s) { return &s->stats; }
        void fatrop_ocp_c_destroy(FatropOcpCSolver *s) { delete s; }
    }
} // namespace fatrop

// The caller's side: ask for a warm start of the multipliers (least bound multiplier ``floor``) in the
// next solve of this thread, or not (``on`` 0); how many iterations the last solve of this thread took.
extern "C" void hitchpark_fatrop_set_warm(int on, double floor)
{
    warm_requested = on != 0;
    warm_floor = floor;
}

extern "C" int hitchpark_fatrop_last_iterations(void) { return last_iterations; }
